"""The package layout by layer (DESIGN.md section 2): each layer imports only the
layers before it, renderers only format (no derivation inside), and no module grows past
the size a reader takes in at once. Checked on the source's own import statements."""

from __future__ import annotations

import ast
import importlib
import re
from pathlib import Path

import pytest

import dynderive

PACKAGE = Path(dynderive.__file__).resolve().parent

#: Layers in pipeline order; a module may import its own layer and the layers before it.
#: ``errors`` and ``_version`` are leaves every layer may use.
LAYERS = ["model", "input", "mechanics", "derivation", "render", "verify", "commands"]
LEAVES = {"errors", "_version"}
#: What the renderers may take from the engine: pure helpers, never a derivation step.
RENDER_MAY_USE = {"mechanics.tidy"}


def _layer(module: str) -> str:
    return module.split(".")[0]


def _modules():
    for path in sorted(PACKAGE.rglob("*.py")):
        parts = list(path.relative_to(PACKAGE).with_suffix("").parts)
        package = parts[:-1] if parts[-1] != "__init__" else parts[:-1]
        yield path, ".".join(p for p in parts if p != "__init__"), package


def _imports(path: Path, package: list[str], typing: bool = True) -> set[str]:
    """Modules of dynderive that ``path`` imports (absolute dotted names inside the package);
    without ``typing``, not those under ``if TYPE_CHECKING:`` (names for annotations only,
    never imported when the program runs)."""
    found = set()
    tree = ast.parse(path.read_text())
    if not typing:
        for node in ast.walk(tree):
            if isinstance(node, ast.If) and isinstance(node.test, ast.Name) and node.test.id == "TYPE_CHECKING":
                node.body = []
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom):
            if node.level:
                base = package[: len(package) - (node.level - 1)]
                target = ".".join(base + ([node.module] if node.module else []))
                if node.module is None:   # from . import x: x may be a module
                    found |= {".".join([*base, a.name]).lstrip(".") for a in node.names}
                else:
                    found.add(target)
            elif node.module and node.module.startswith("dynderive."):
                found.add(node.module[len("dynderive."):])
    return {f for f in found if f}


MODULES = [(str(path.relative_to(PACKAGE)), module, package) for path, module, package in _modules()]


@pytest.mark.parametrize("relative, module, package", MODULES, ids=[m[0] for m in MODULES])
def test_each_layer_imports_only_the_layers_before_it(relative, module, package):
    layer = _layer(module)
    if layer not in LAYERS:   # the package root, __main__ and the leaves sit outside the pipeline
        return
    allowed = set(LAYERS[: LAYERS.index(layer) + 1]) | LEAVES
    for target in _imports(PACKAGE / relative, package):
        target_layer = _layer(target)
        if target_layer not in LAYERS and target_layer not in LEAVES:
            continue   # names imported from the package root are checked below
        assert target_layer in allowed, f"{module} (layer {layer}) imports {target} (layer {target_layer})"
        if layer == "render" and target_layer == "mechanics":
            assert target in RENDER_MAY_USE, f"{module} calls into the engine ({target}): renderers only format"


def test_only_commands_and_the_package_root_use_the_package_root():
    """``from .. import derive`` inside a layer would hide a dependency on every layer."""
    for relative, module, package in MODULES:
        if _layer(module) in LAYERS and _layer(module) != "commands":
            tree = ast.parse((PACKAGE / relative).read_text())
            for node in ast.walk(tree):
                if isinstance(node, ast.ImportFrom) and node.level and node.module is None:
                    assert len(package) - (node.level - 1) > 0, f"{module} imports from the package root"


@pytest.mark.parametrize("relative", [m[0] for m in MODULES])
def test_modules_stay_readable(relative):
    assert len((PACKAGE / relative).read_text().splitlines()) <= 600, f"{relative}: split it by purpose"


def _module_of(target: str, known: set[str]) -> str | None:
    """``target`` (``a.b.name``) as a module of the package: itself, or its package when the
    last part is a name imported from it."""
    if target in known:
        return target
    parent = target.rsplit(".", 1)[0] if "." in target else ""
    return parent if parent in known else None


def test_no_module_imports_itself_through_others():
    """No import circle, counting imports inside functions too (a lazy import hides a circle
    but does not remove it: the two modules still cannot be understood one before the other),
    and names imported for annotations only (``if TYPE_CHECKING:``) too: a type both modules
    need lives where both import it one way. Packages (``__init__``) are left out: the root's
    lazy re-exports point down by design."""
    known = {module for _, module, _ in MODULES}
    graph = {module: {m for t in _imports(PACKAGE / relative, package)
                      if (m := _module_of(t, known)) and m != module and m not in _PACKAGES}
             for relative, module, package in MODULES if module not in _PACKAGES}
    circles = []
    for start in sorted(graph):
        stack, seen = [(start, [start])], set()
        while stack:
            module, path = stack.pop()
            for target in sorted(graph.get(module, ())):
                if target == start:
                    circles.append(" -> ".join(path + [start]))
                elif target not in seen:
                    seen.add(target)
                    stack.append((target, path + [target]))
    assert not circles, circles[:5]


_PACKAGES = {module for relative, module, _ in MODULES if relative.endswith("__init__.py")}

def test_one_engine_for_every_robot_class():
    """A floating base or a spherical joint is a joint type, not a second pipeline: no module
    or template of any layer is named for it (``mechanics/tree.py`` serves every robot, each
    target and each sheet renders every robot)."""
    from dynderive.render.environment import builtin_template_dirs

    named = sorted([relative for relative, module, _ in MODULES if "floating" in relative.rsplit("/", 1)[-1]]
                   + [path.name for templates in builtin_template_dirs() for path in templates.rglob("*.j2")
                      if "floating" in path.name])
    assert not named, named


def test_a_target_is_one_folder():
    """A target's templates live in its folder beside its printer (``render/targets/<folder>/``):
    the shared ``templates/`` has no folder named for a target, and every template a target
    lists is found in the targets' folder."""
    from dynderive.render.environment import builtin_templates_dir, target_templates_dir
    from dynderive.render.targets import TARGETS

    folders = {path.name for path in target_templates_dir().iterdir() if path.is_dir()}
    assert {"c", "numpy", "jax"} <= folders
    assert not [path.name for path in builtin_templates_dir().iterdir() if path.name in folders]
    for target in TARGETS:
        for name in target.templates:
            if "/" in name:
                assert (target_templates_dir() / name).is_file(), (target.name, name)


def _target_conditions(text: str, names: set[str]) -> list[str]:
    """The Jinja conditions of ``text`` (``{% if %}``, ``{% elif %}`` and inline ``x if c else y``)
    that name a target (a registry name or kind, or the word ``target``)."""
    found = []
    for tag in re.findall(r"\{%-?\+?(.*?)[-+]?%\}|\{\{(.*?)\}\}", text, flags=re.S):
        statement, expression = tag
        condition = statement if re.match(r"\s*(el)?if\b", statement) else expression if " if " in expression else ""
        words = set(re.findall(r"[A-Za-z_][A-Za-z_0-9]*", re.sub(r"(\"[^\"]*\"|'[^']*')", "", condition)))
        if words & names:
            found.append(condition.strip())
    return found


def test_shared_templates_branch_on_no_target():
    """What differs between targets is data the target supplies (its ``python_backend``
    macros, its own templates), never a branch on the target's name in a template that several
    targets or the sheets render: the top-level templates, ``sections/`` and ``html/``."""
    from dynderive.render.environment import builtin_templates_dir
    from dynderive.render.targets import TARGETS

    # a one-letter name (C's "c") reads as a loop variable: the longer names and kinds are checked
    names = {word for target in TARGETS for word in (target.name, target.kind) if len(word) > 1}
    names |= {"target", "torch", "pytorch"}
    assert {"jax", "casadi", "numpy", "matlab"} <= names
    assert _target_conditions("{% if jax %}a{% endif %}{{ 'np' if numpy else '_jnp' }}", names) == [
        "if jax", "'np' if numpy else '_jnp'"]
    assert not _target_conditions("{% if loops %}{{ b.zeros(n, 'jax') }}{% endif %}", names)
    templates = builtin_templates_dir()
    shared = [*templates.glob("*.j2"), *(templates / "sections").rglob("*.j2"), *(templates / "html").rglob("*.j2")]
    assert len(shared) > 10
    branches = {str(path.relative_to(templates)): conditions for path in shared
                if (conditions := _target_conditions(path.read_text(), names))}
    assert not branches, branches


def test_public_api_keeps_working():
    robot = dynderive.load_robot("rp_arm")
    d = dynderive.derive(robot)
    assert d.keys()[:3] == ["T_g", "V_g", "L_g"] and "M_g" in d.keys()
    assert "M(q)" in d._repr_latex_() and d._repr_latex_().startswith("$")
    assert set(d.programs) == {"inverse_dynamics", "forward_dynamics", "regressor", "inverse_dynamics_derivatives"}
    for name in ("render_latex", "render_code", "render_json", "lagrange_equations", "christoffel_coriolis",
                 "gravity_vector", "constraint_jacobian_dot", "time_derivative", "Robot", "InputError",
                 "__version__"):
        assert getattr(dynderive, name) is not None


def test_nothing_user_facing_names_the_internal_tracker():
    """Users cannot see the project's issue numbers: messages, docstrings, templates, docs and
    the README say what is built and what is not, never "issue N"."""
    root = Path(__file__).resolve().parents[1]   # the checkout (the installed package has no docs)
    places = [root / "src", root / "templates", root / "docs", root / "README.md", root / "examples" / "ci"]
    pattern = __import__("re").compile(r"\bissues? #?[0-9]+", __import__("re").IGNORECASE)
    found = []
    assert all(place.exists() for place in places)
    for place in places:
        files = [place] if place.is_file() else sorted(p for p in place.rglob("*") if p.is_file()
                                                         and p.suffix in {".py", ".j2", ".md", ".yml", ".yaml"})
        for path in files:
            for number, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1):
                if pattern.search(line):
                    found.append(f"{path.relative_to(root)}:{number}: {line.strip()[:80]}")
    assert found == []


def test_every_registered_target_has_its_folder():
    """A code target is a folder of ``render/targets/`` whose ``__init__.py`` holds its
    registry entry (``TARGET``), named by the target (``c_extension`` for ``c-extension``);
    every such folder is registered."""
    from dynderive.render import targets

    folder = PACKAGE / "render" / "targets"
    registered = {target.folder for target in targets.TARGETS}
    assert len(registered) == len(targets.TARGETS)
    folders = {path.parent.name for path in folder.glob("*/__init__.py")}
    assert folders == registered
    for target in targets.TARGETS:
        module = importlib.import_module(f"dynderive.render.targets.{target.folder}")
        assert module.TARGET is target
        for field in ("render", "offered", "needs", "note", "failure", "fingerprint"):
            function = getattr(target, field)
            assert function is None or callable(function), (target.name, field, function)
    from dynderive.verify.backends import HARNESSES

    for harness in HARNESSES:   # a harness runs a registered target
        assert harness.target.name == harness.name and callable(harness.load) and callable(harness.needs)


def test_no_command_names_a_target():
    """The commands loop over the registry (``render.targets``): none imports a target's
    modules, lazily or not, nor names one in a string."""
    found = []
    for relative, module, package in MODULES:
        if _layer(module) != "commands":
            continue
        for target in _imports(PACKAGE / relative, package):
            if target.startswith("render.targets."):
                found.append(f"{relative}: imports {target}")
        if "render.targets." in (PACKAGE / relative).read_text():
            found.append(f"{relative}: names a module of render.targets")
    assert found == []


def test_no_target_imports_another_target():
    """A target's modules import the code-generation layer (``render/codegen/``), the engine
    and ``render/``'s shared modules, never another target's folder (relative or absolute,
    lazily or not), nor names one in a string (``"package.module:function"``): what
    two targets share lives in ``codegen``; the extension reaches the C target's files through
    the registry, and ``check``/``simulate --backend c`` reach the extension through
    ``verify/backends.py``."""
    folders = {path.parent.name for path in (PACKAGE / "render" / "targets").glob("*/__init__.py")}
    found = []
    for relative, module, package in MODULES:
        parts = module.split(".")
        if parts[:2] != ["render", "targets"] or len(parts) < 3 or parts[2] not in folders:
            continue
        for target in _imports(PACKAGE / relative, package):
            other = target.split(".")
            if other[:2] == ["render", "targets"] and len(other) > 2 and other[2] in folders - {parts[2]}:
                found.append(f"{relative}: imports {target}")
        found += [f"{relative}: names {name}" for name in _named_targets((PACKAGE / relative).read_text(), folders - {parts[2]})]
    assert found == []


def _named_targets(text: str, folders: set[str]) -> list[str]:
    """The modules of the target folders ``folders`` that ``text`` names in full
    (``dynderive.render.targets.c_extension.compile:...``, as a registry string does)."""
    return [match.group(0) for match in re.finditer(r"dynderive\.render\.targets\.(\w+)[.:][\w.:]*", text)
            if match.group(1) in folders]


def test_the_target_check_sees_a_registry_string_naming_another_target():
    text = ('TARGET = Target(load="dynderive.render.targets.c_extension.compile:compiled_module",\n'
            '                render=f"{__name__}:render", check="dynderive.verify.backends:compiled_backend")\n')
    assert _named_targets(text, {"c_extension", "numpy"}) == ["dynderive.render.targets.c_extension.compile:compiled_module"]
    assert _named_targets(text, {"numpy"}) == []


def test_the_import_check_sees_relative_and_absolute_imports(tmp_path):
    """The parser behind the target check reads both spellings of an import of another target."""
    source = tmp_path / "m.py"
    source.write_text("from ..c.c_print import CFunction\nfrom dynderive.render.targets.numpy import code\n"
                      "def f():\n    from ...codegen.names import refuse\n")
    assert _imports(source, ["render", "targets", "matlab"]) == {
        "render.targets.c.c_print", "render.targets.numpy", "render.codegen.names"}


def test_no_benchmark_script_shadows_a_package():
    """Tests put ``benchmarks/`` on ``sys.path`` (to import its anchors): a script named like a
    package the project or its tests import (``casadi.py``) would be imported in its place."""
    imported = {"dynderive", "numpy", "sympy", "scipy", "jax", "casadi", "pinocchio", "adam", "liecasadi",
                "matplotlib", "yaml", "jinja2", "typer", "pytest", "hypothesis", "jsonschema", "example_robot_data"}
    scripts = list((Path(__file__).resolve().parents[1] / "benchmarks").glob("*.py"))
    assert scripts   # the checkout's benchmarks, not an installed copy
    shadowing = [s.name for s in scripts if s.stem in imported]
    assert not shadowing, f"benchmark scripts named like packages: {shadowing}"


#: The templates of the generated Python modules (NumPy, JAX, PyTorch, CasADi): written once over
#: NQ and NV, they never ask which kind of joint a robot has.
CODE_TEMPLATES = ["dynamics*.py.j2", "python_api.j2", "loop_solve.py.j2"]
CODE_TARGETS = ("jax", "torch", "casadi", "numpy")
#: The words that would make a template branch on the robot's joints rather than on what its code needs.
KIND_WORDS = re.compile(r"\b(floating|floating_base|spherical)\b")


def _kind_branches(text: str) -> list[str]:
    """The Jinja tags and expressions of ``text`` (comments aside) that read a robot-kind flag."""
    tags = re.findall(r"\{[%{]-?(.*?)-?\+?[%}]\}", text, re.S) + re.findall(r"\\(?:BLOCK|VAR)\{([^}]*)\}", text)
    return [tag.strip() for tag in tags if KIND_WORDS.search(tag)]


def test_no_code_template_branches_on_the_robot_kind():
    root = Path(__file__).resolve().parents[1]   # the checkout (CI installs the package elsewhere)
    paths = [p for pattern in CODE_TEMPLATES for p in sorted((root / "templates").glob(pattern))]
    targets = root / "src" / "dynderive" / "render" / "targets"
    paths += [p for target in CODE_TARGETS for p in sorted((targets / target).glob("*.j2"))]
    assert len(paths) > 15   # the checkout's templates, found
    found = {str(p.relative_to(root)): _kind_branches(p.read_text()) for p in paths}
    assert not {path: tags for path, tags in found.items() if tags}


def test_no_sheet_template_branches_on_the_robot_kind():
    """Every template (the sheets' LaTeX and HTML, linearize's, the code): what differs for a
    robot with quaternion joints comes from the context by what it is (``quaternion_joints``,
    ``free_body``, the centroidal steps' ``base``, ``tangent_space``), never a floating flag."""
    root = Path(__file__).resolve().parents[1]
    paths = sorted((root / "templates").rglob("*.j2")) + sorted((root / "src" / "dynderive").rglob("*.j2"))
    assert len(paths) > 40
    found = {str(p.relative_to(root)): _kind_branches(p.read_text()) for p in paths}
    assert not {path: tags for path, tags in found.items() if tags}


def test_the_kind_check_sees_a_branch_and_not_a_comment():
    assert _kind_branches("{% if floating %}x{% endif %}{{ 'a' if floating_base }}") == ["if floating", "'a' if floating_base"]
    assert _kind_branches("{%- if loops and not spherical +%}") == ["if loops and not spherical"]
    assert _kind_branches("{#- the floating type of a result #}{{ robot_kind }} the floating type") == []
    assert _kind_branches(r"\BLOCK{if floating_base}x\BLOCK{endif} the floating base \VAR{free_body}") == ["if floating_base"]


def test_derivations_and_robots_are_typed_parameters():
    """No function takes a ``derivation`` or a ``robot`` typed ``Any`` (or not typed): what a
    renderer or a command receives says what it is (``Derivation``, ``Robot``)."""
    found = []
    for relative, _, _ in MODULES:
        tree = ast.parse((PACKAGE / relative).read_text(encoding="utf-8"))
        for node in ast.walk(tree):
            if not isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.Lambda)):
                continue
            arguments = node.args
            for argument in (*arguments.posonlyargs, *arguments.args, *arguments.kwonlyargs):
                if argument.arg not in ("derivation", "robot") or isinstance(node, ast.Lambda):
                    continue
                annotation = ast.unparse(argument.annotation) if argument.annotation is not None else None
                if annotation is None or "Any" in annotation:
                    found.append(f"{relative}:{node.lineno}: {node.name}({argument.arg}: {annotation})")
    assert found == []
