"""The reference pages' generated parts: written into the committed Markdown, so that they read
on GitHub too, and checked to be current, so that they cannot drift.

A page holds a region between two marker lines, generated from the code:

- ``<!-- generated: cli -->``: every command of ``dynderive`` with its usage and options, read
  from the Typer/click application itself (``dynderive.commands.cli.app``);
- ``<!-- generated: robot-schema -->``: every key of the robot file, read from the JSON Schema
  (``dynderive.input.json_schema.robot_schema``, what ``dynderive schema`` prints);
- ``<!-- generated: joint-types -->``: the joint types, their sizes and entry names, read from
  the joint specification (``dynderive.model.joint_kinds.JOINT_KINDS``);

each region ending at ``<!-- end generated -->``. Update them from the repository root with::

    python docs/hooks/generated.py --write

and check them with ``--check`` (exit 1 naming the stale pages; ``tests/test_docs.py`` does
the same). As an MkDocs hook the module puts the freshly generated text into the site and
warns about a stale page, which fails ``mkdocs build --strict``.

The functions are plain and importable (``tests/test_docs.py`` uses them too). The checkout's
``src/`` comes first on ``sys.path``: the documentation describes this checkout.
"""

from __future__ import annotations

import logging
import re
import sys
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[2]
if str(ROOT / "src") not in sys.path:
    sys.path.insert(0, str(ROOT / "src"))

#: The generated regions: their name, the page holding them (under docs/) and their maker.
REGIONS = {
    "cli": ("reference/cli.md", lambda: cli_markdown()),
    "robot-schema": ("reference/robot-format.md", lambda: schema_markdown()),
    "joint-types": ("reference/robot-format.md", lambda: joint_types_markdown()),
}
END = "<!-- end generated -->"
UPDATE = "python docs/hooks/generated.py --write"
REGION = re.compile(r"^<!-- generated: (?P<name>[a-z-]+) -->\n(?P<body>.*?)^" + re.escape(END) + r"$",
                    re.S | re.M)


def escape(text: str) -> str:
    """Plain text for a Markdown table cell: no HTML, emphasis, links or cell breaks."""
    text = " ".join(text.split())
    for char in "\\`*_[]|":
        text = text.replace(char, "\\" + char)
    return text.replace("<", "&lt;").replace(">", "&gt;")


# ----------------------------------------------------------------------------- command line


def cli_markdown() -> str:
    import click
    import typer

    from dynderive.commands.cli import app

    group = typer.main.get_command(app)
    root = click.Context(group, info_name="dynderive")
    names = group.list_commands(root)
    lines = ["| Command | What it does |", "|---|---|"]
    for name in names:
        command = group.get_command(root, name)
        lines.append(f"| [`{name}`](#dynderive-{name}) | {escape(_first_line(command.help or ''))} |")
    lines.append("")
    for name in names:
        command = group.get_command(root, name)
        context = click.Context(command, info_name=name, parent=root)
        lines += [f"### `dynderive {name}`", "", escape(command.help or "").replace("\\_", "_"), "",
                  "```", _usage(name, command, context), "```", "",
                  "| Argument or option | Description |", "|---|---|"]
        for param in command.get_params(context):
            record = param.get_help_record(context)
            if record is None:
                continue
            opts, help_text = record
            if param.param_type_name == "argument":
                opts = param.name.upper()
            lines.append(f"| `{opts}` | {escape(help_text)} |")
        lines.append("")
    return "\n".join(lines)


def _first_line(text: str) -> str:
    return " ".join(text.split("\n\n")[0].split())


def _usage(name: str, command: Any, context: Any) -> str:
    pieces = ["dynderive", name, "[OPTIONS]"]
    for param in command.get_params(context):
        if param.param_type_name == "argument":
            word = param.name.upper() + ("..." if param.nargs == -1 else "")
            pieces.append(word if param.required else f"[{word}]")
    return " ".join(pieces)


# ----------------------------------------------------------------------------- robot format


def joint_types_markdown() -> str:
    """The table of joint types: NQ, NV, where a file may write it, the names of a joint
    ``j``'s entries (efforts of an effort ``e``), its URDF and MuJoCo names."""
    from dynderive.model.joint_kinds import JOINT_KINDS

    def names(prefix: str, suffixes: tuple[str, ...] | None, single: str) -> str:
        if suffixes is None:
            return "rates of the coordinates"
        if not suffixes:
            return single
        return escape(", ".join(f"{prefix}_{s}" for s in suffixes))

    mjcf = {0: "free", 1: "ball", 2: "slide", 3: "hinge"}
    lines = ["| type | NQ | NV | robots | coordinates of joint `j` | velocities | efforts of effort `e` "
             "| URDF | MJCF | what it is |", "|" + "---|" * 10]
    for kind in JOINT_KINDS.values():
        where = " and ".join(w for w, ok in (("planar", kind.planar), ("3-D", kind.spatial)) if ok)
        single = "none" if kind.welded else "`j`"
        lines.append(" | ".join((
            f"| `{kind.name}`", str(kind.nq), str(kind.nv), where,
            names("j", kind.coordinates, single),
            "none" if kind.welded else names("j", kind.velocities, single),
            names("e", kind.efforts, "none" if kind.welded else "`e`"),
            ", ".join(f"`{t}`" for t in kind.urdf) or "-", ", ".join(f"`{mjcf[t]}`" for t in kind.mjcf) or "-",
            escape(kind.summary)),) + " |")
    return "\n".join(lines) + "\n"


def schema_markdown() -> str:
    from dynderive.input.json_schema import robot_schema

    schema = robot_schema()
    lines: list[str] = []
    _object(schema, "Top level", "", lines)
    return "\n".join(lines)


def _object(node: dict[str, Any], title: str, path: str, lines: list[str]) -> None:
    required = set(node.get("required", []))
    nested: list[tuple[dict[str, Any], str, str]] = []
    lines += [f"### {title}", ""]
    if node.get("description"):
        text = escape(node["description"])
        lines += [text[:1].upper() + text[1:] + ".", ""]
    lines += ["| Key | Required | Value | Description |", "|---|---|---|---|"]
    for key, value in node.get("properties", {}).items():
        where = f"{path}.{key}" if path else key
        if value.get("type") == "object" and "properties" in value:
            nested.append((value, f"`{where}`", where))
            kind = "mapping (below)"
        elif value.get("type") == "array" and isinstance(value.get("items"), dict) \
                and value["items"].get("type") == "object":
            nested.append((value["items"], f"Each entry of `{where}`", where + "[]"))
            kind = "list of mappings (below)"
        elif value.get("type") == "object" and "additionalProperties" in value:
            nested.append((value, f"Each entry of `{where}`", where + ".NAME"))
            kind = "mapping of names (below)"
        else:
            kind = _kind(value)
        lines.append(f"| `{key}` | {'yes' if key in required else 'no'} | {kind} | "
                     f"{escape(value.get('description', ''))} |")
    lines.append("")
    for child, child_title, child_path in nested:
        if "properties" in child:
            _object(child, child_title, child_path, lines)
        else:   # a mapping of names to values: parameters
            names = child.get("propertyNames", {}).get("pattern")
            lines += [f"### {child_title}", ""]
            if names:
                lines += [f"Names match `{names}`. Each value is one of:", ""]
            for option in child["additionalProperties"].get("oneOf", []):
                if option.get("type") == "object":
                    keys = ", ".join(f"`{k}` ({_kind(v)})" for k, v in option["properties"].items())
                    lines.append(f"- a mapping with the keys {keys}")
                else:
                    lines.append(f"- {_kind(option)}: {escape(option.get('description', ''))}")
            lines.append("")


def _kind(value: dict[str, Any], plural: bool = False) -> str:
    """A short description of a schema node's values (``plural``: of several of them)."""
    s = "s" if plural else ""
    if "enum" in value:
        return " \\| ".join(f"`{v}`" for v in value["enum"])
    if "oneOf" in value:
        kinds = [_kind(v, plural) for v in value["oneOf"]]
        if kinds in (["number", "text"], ["numbers", "texts"]):
            return "expression" + s
        return " or ".join(kinds)
    kind = value.get("type")
    if isinstance(kind, list):
        return " or ".join(_kind({"type": k}, plural) for k in kind)
    if kind == "array":
        low, high = value.get("minItems"), value.get("maxItems")
        items = value.get("items", {})
        if items.get("type") == "array":   # a matrix
            return f"{low} x {items.get('minItems')} list{s} of {_kind(items.get('items', {}), True)}"
        inner = _kind(items, True)
        if low is not None and high is not None:
            count = str(low) if low == high else f"{low} or {high}" if high - low == 1 else f"{low} to {high}"
            return f"list{s} of {count} {inner}"
        if low:
            return f"list{s} of {inner} (at least {low})"
        return f"list{s} of {inner}"
    if kind == "string":
        return f"identifier{s} (`{value['pattern']}`)" if "pattern" in value else "text" + s
    if kind == "boolean":
        return "true or false" + (f" (default {str(value['default']).lower()})" if "default" in value else "")
    if kind == "null":
        return "`~` (no default)"
    return {"number": "number", "object": "mapping"}.get(kind, "any") + s


# ----------------------------------------------------------------------------- the pages


def regenerate(markdown: str, made: dict[str, str] | None = None) -> str:
    """``markdown`` with every generated region's text made afresh (markers kept)."""
    made = {} if made is None else made

    def fresh(match: re.Match[str]) -> str:
        name = match["name"]
        if name not in REGIONS:
            raise ValueError(f"unknown generated region {name!r} (known: {', '.join(REGIONS)})")
        if name not in made:
            made[name] = REGIONS[name][1]()
        return f"<!-- generated: {name} -->\n{made[name].rstrip()}\n{END}"

    return REGION.sub(fresh, markdown)


def stale_pages(write: bool = False) -> list[str]:
    """The pages (relative to the repository) whose generated regions are not current; with
    ``write``, rewrites them. A page without its region counts as stale (and is not fixed)."""
    stale, made = [], {}
    for name, (page, _) in REGIONS.items():
        path = ROOT / "docs" / page
        text = path.read_text(encoding="utf-8")
        if f"<!-- generated: {name} -->" not in text:
            stale.append(f"docs/{page} (no '<!-- generated: {name} -->' ... '{END}' region)")
            continue
        new = regenerate(text, made)
        if new != text:
            stale.append(f"docs/{page}")
            if write:
                path.write_text(new, encoding="utf-8")
    return stale


def main(argv: list[str]) -> int:
    """``--write``: rewrite the stale pages; ``--check``: name them. Exit 1 when a page is
    stale (``--check``) or has no region (either), else 0."""
    if argv not in (["--write"], ["--check"]):
        print("usage: python docs/hooks/generated.py --write | --check", file=sys.stderr)
        return 2
    write = argv == ["--write"]
    stale = stale_pages(write=write)
    missing = [page for page in stale if page.endswith("region)")]
    for page in stale:
        print(f"{page}: {'rewritten' if write and page not in missing else 'not current'}")
    if stale and not write:
        print(f"update with: {UPDATE}")
    return 1 if missing or (stale and not write) else 0


# ----------------------------------------------------------------------------- the hook


def on_page_markdown(markdown: str, page: Any, config: Any, files: Any) -> str:
    """The site shows the generated text as made now, without the marker comments; a page
    whose committed text is stale is a warning (an error under ``--strict``)."""
    new = regenerate(markdown)
    if new != markdown:
        logging.getLogger("mkdocs.hooks.generated").warning(
            "%s: its generated reference is not current; update with: %s", page.file.src_path, UPDATE)
    return REGION.sub(lambda match: match["body"], new)


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
