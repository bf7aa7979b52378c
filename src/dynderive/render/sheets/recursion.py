"""A large robot's sheet as a recursion a reader can follow (OpenSYMORO's customized
Newton-Euler, better named): the links' kinematic data, then every line of the program
``Derivation.recursion`` named by what it means and by its link (``\\omega_{3x}``, the
x-component of link 3's angular velocity, in link 3's axes; ``\\bar\\omega_{3x}``, the
parent's, in link 3's axes), grouped link by link.

Names come from the lines' recorded meanings (``program.Meaning``); values that cost nothing
to repeat (``\\dot q_1``, ``-s_2``) are printed as they are, zero components left out. The
sheet's ``recursion.tex.j2`` states the recursion in symbols around these lines.
"""

from __future__ import annotations

from typing import Any

import sympy

from ...derivation import Derivation
from ...model.robot import Robot
from ..encode import escape_tex

AXES = "xyz"
#: LaTeX of each quantity (``recursion.MEANINGS``): ``{i}`` the link's index, ``{j}`` the mass
#: matrix's column, ``{k}`` the coordinate's, ``{c}`` the component. A bar marks a vector carried
#: across joint i into the other link's axes (the parent's motion into link i's, link i's
#: forces into the parent's): no left superscript next to a coefficient.
NAMES = {
    "R": "R_{{{i},{c}}}", "p": "p_{{{i}{c}}}", "m": "m_{{{i}}}", "h": "h_{{{i}{c}}}", "I": "I_{{{i},{c}}}",
    "omega_in": "\\bar\\omega_{{{i}{c}}}", "v_in": "\\bar v_{{{i}{c}}}",
    "alpha_in": "\\bar{{\\dot\\omega}}_{{{i}{c}}}", "a_in": "\\bar a_{{{i}{c}}}",
    "omega": "\\omega_{{{i}{c}}}", "v": "v_{{{i}{c}}}", "alpha": "\\dot\\omega_{{{i}{c}}}", "a": "a_{{{i}{c}}}",
    "k": "k_{{{i}{c}}}", "l": "\\ell_{{{i}{c}}}", "F": "F_{{{i}{c}}}", "N": "N_{{{i}{c}}}",
    "f_up": "\\bar f_{{{i}{c}}}", "n_up": "\\bar n_{{{i}{c}}}", "f": "f_{{{i}{c}}}", "n": "n_{{{i}{c}}}",
    "tau": "\\tau_{{{k}}}", "mc": "m^c_{{{i}}}", "hc": "h^c_{{{i}{c}}}", "Ic": "I^c_{{{i},{c}}}",
    "hc_up": "\\bar h^c_{{{i}{c}}}", "IRt": "U_{{{i},{c}}}",
    "Fcol": "f^{{({j})}}_{{{i}{c}}}", "Ncol": "n^{{({j})}}_{{{i}{c}}}", "M": "M_{{{c}}}",
}
#: Estimated width (math glyphs) of a line in one of the sheet's two columns of small type,
#: less the name in front, the indent of continuation lines and the estimate's error: a term
#: wider than this (a product with a sum in parentheses) is broken by ``render.linebreak``.
COLUMN_UNITS = 30
#: Quantities shown only where they are lines: the rest (numbers, the robot's parameters) are
#: in the kinematic data table, or the matrices M_g and tau at the end.
ONLY_LINES = {"p", "m", "h", "I", "mc", "hc", "Ic", "hc_up", "IRt", "M", "tau"}
FORWARD = ("R", "p", "m", "h", "I", "omega_in", "v_in", "alpha_in", "a_in", "omega", "v", "alpha", "a",
           "k", "l", "N", "F")
BACKWARD = ("tau", "f_up", "n_up", "f", "n")
COMPOSITE = ("hc_up", "IRt", "Ic", "mc", "hc")
COLUMNS = ("Fcol", "Ncol", "M")


def _component(quantity: str, index: tuple[int, ...], n: int) -> str:
    if quantity == "M":   # as the sheet's entries: M_{12}, M_{1,12} beyond 9 coordinates
        return f"{index[0] + 1},{index[1] + 1}" if n > 9 else f"{index[0] + 1}{index[1] + 1}"
    if quantity in ("R", "IRt"):
        return f"{index[0] + 1}{index[1] + 1}"
    return "".join(AXES[k] for k in index)


def named_lines(derivation: Derivation) -> dict[sympy.Symbol, tuple[Any, int]]:
    """Each labelled line of the recursion's program: its meaning and how many primes its name
    takes (a meaning met again, as a partial sum over a link's children: one more each time).
    Format-neutral: the LaTeX and the MathML names both follow it."""
    robot, r = derivation.robot, derivation.recursion
    index = link_indices(robot)
    found: dict[sympy.Symbol, tuple[Any, int]] = {}
    seen: dict[str, int] = {}
    for symbol, _ in r.program.lines:
        meaning = r.program.labels.get(symbol)
        if meaning is None:
            continue
        text = _name(meaning, index, robot, len(robot.coordinates))
        found[symbol] = (meaning, seen.get(text, 0))
        seen[text] = seen.get(text, 0) + 1
    return found


def coordinate_index(derivation: Derivation, value: sympy.Expr) -> str:
    """k of a sine or cosine of the recursion (``s_k``, ``c_k``): its coordinate's index from 1;
    ``k,i`` for a <mimic> joint's (link i's joint, following coordinate k)."""
    q = derivation.symbols.q
    if value.args[0] in q:
        return str(1 + q.index(value.args[0]))
    return next(f"{k},{i}" for k, i, variable in mimic_variables(derivation) if value.args[0] in (variable, -variable))


def mimic_variables(derivation: Derivation) -> list[tuple[int, int, sympy.Expr]]:
    """Each revolute <mimic> joint's leader coordinate k (from 1), link index i and variable
    (the ones with sines and cosines of their own)."""
    robot, table = derivation.robot, derivation.symbols
    index = link_indices(robot)
    found = []
    for joint in (j for j in robot.joints if j.mimic is not None and j.kind.angle):
        leader, multiplier, offset = robot.driver(joint)
        k = robot.coordinates.index(leader)
        found.append((k + 1, index[joint.child], table.expr(multiplier) * table.q[k] + table.expr(offset)))
    return found


def latex_coordinate(letter: str, dots: int, k: str) -> str:
    """LaTeX of ``q_k`` (``dots`` its rates) or of a sine or cosine ``s_k``/``c_k``."""
    return ("", "\\dot ", "\\ddot ")[dots] + f"{letter}_{{{k}}}"


def latex_line(quantity: str, fields: dict[str, Any], primes: int = 0) -> str:
    """LaTeX of a line meaning ``quantity`` (``name_fields``), primed."""
    text = NAMES[quantity].format(**fields)
    if "^" in text:   # a group, so that a power or a prime is not a second superscript
        text = "{" + text + "}"
    return text + "'" * primes


def recursion_names(derivation: Derivation, coordinate: Any = latex_coordinate, line: Any = latex_line) -> dict:
    """Every name of the recursion's program, LaTeX unless ``coordinate`` and ``line`` write
    them (MathML: ``html_recursion``): ``q_k`` and its rates and ``s_k``/``c_k`` the sines and
    cosines of coordinate k (``coordinate(letter, dots, k)``), its lines by meaning
    (``line(quantity, name_fields, primes)``, primed as ``named_lines`` says)."""
    robot, r, table = derivation.robot, derivation.recursion, derivation.symbols
    index, n = link_indices(robot), len(robot.coordinates)
    names = {}
    for k in range(len(table.q)):   # OpenSYMORO's short names: q_k the coordinate of joint k
        names |= {s: coordinate("q", dots, str(k + 1)) for dots, s in enumerate((table.q[k], table.qd[k], table.qdd[k]))}
    for symbol, value in r.trig:
        names[symbol] = coordinate("c" if isinstance(value, sympy.cos) else "s", 0, coordinate_index(derivation, value))
    for symbol, (meaning, primes) in named_lines(derivation).items():
        names[symbol] = line(meaning.quantity, name_fields(meaning, index, robot, n), primes)
    return names


def link_indices(robot: Robot) -> dict[str, int]:
    """Each link's index from 1 (the world 0)."""
    return {link.name: k for k, link in enumerate(robot.links, 1)} | {"world": 0}


def name_fields(meaning: Any, index: dict[str, int], robot: Robot, n: int) -> dict[str, Any]:
    """What a line's name shows (NAMES' fields): ``i`` the link's index, ``j`` the column's,
    ``k`` the coordinate's (0 for a fixed joint), ``c`` the component's text."""
    joint = robot.parent_joint(meaning.link)
    k = robot.coordinates.index(robot.driver(joint)[0]) + 1 if joint.moves else 0
    return {"i": index[meaning.link], "j": meaning.column + 1, "k": k, "c": _component(meaning.quantity, meaning.index, n)}


def _name(meaning: Any, index: dict[str, int], robot: Robot, n: int) -> str:
    return NAMES[meaning.quantity].format(**name_fields(meaning, index, robot, n))


def recursion_parts(derivation: Derivation, width: Any) -> dict[str, Any]:
    """What a large robot's sheet shows of the recursion, format-neutral (SymPy values; the
    LaTeX ``recursion_context`` and the HTML page's print them): ``forward``, ``backward``,
    ``composite``, ``columns`` (blocks of ``link`` (or None), ``index`` (the link's, or the
    column's from 1), ``rotation`` (``R_i`` shown whole, or None: 1, or too wide for the
    column, whose entries are then lines) and ``lines``: each a line of the program
    (``symbol``, ``meaning``, ``value`` its definition) or, ``symbol`` None, ``aliases``: values
    shown as they are (``meaning``, ``value``), as many side by side as fit ALIAS_UNITS),
    ``links`` (the kinematic data, ``_kinematic_rows``) and ``link_index``. ``width``
    estimates a value's width in glyphs."""
    robot, r = derivation.robot, derivation.recursion
    index = link_indices(robot)
    definitions = dict(r.program.lines)
    shown: set[sympy.Symbol] = set()
    rotations = {link: _rotation(link, r) for link in r.order}
    # a rotation too wide for the column (a CAD frame's irrational entries) entry by entry
    wide = {link for link, R in rotations.items() if R is not None and _matrix_width(R, width) > COLUMN_UNITS}

    def line(meaning: Any, value: sympy.Expr) -> dict[str, Any] | None:
        if value.is_Symbol and r.program.labels.get(value) == meaning and value not in shown:
            shown.add(value)
            return {"symbol": value, "meaning": meaning, "value": definitions[value]}
        if value == 0 or meaning.quantity in ONLY_LINES or (meaning.quantity == "R" and meaning.link not in wide):
            return None
        return {"symbol": None, "meaning": meaning, "value": value}

    def blocks(quantities: tuple[str, ...], key: Any, together: bool = False) -> list[dict[str, Any]]:
        """The records of ``quantities`` shown, in blocks of consecutive equal ``key`` (all
        of one key in one block, ``together``)."""
        found: list[dict[str, Any]] = []
        by_key: dict[Any, dict[str, Any]] = {}
        for meaning, value in r.program.records:
            if meaning.quantity not in quantities:
                continue
            item = line(meaning, value)
            if item is None and not (together and key(meaning) not in by_key):
                continue
            if together and key(meaning) in by_key:
                block = by_key[key(meaning)]
            elif not together and found and found[-1]["key"] == key(meaning):
                block = found[-1]
            else:
                column = meaning.quantity in COLUMNS
                block = by_key[key(meaning)] = {
                    "key": key(meaning), "link": None if column else meaning.link,
                    "index": meaning.column + 1 if column else index[meaning.link], "lines": [], "rotation": None}
                found.append(block)
            if item is not None:
                block["lines"].append(item)
        for block in found:
            block["lines"] = _group_aliases(block["lines"], width)
        return found

    forward = sorted(blocks(FORWARD, lambda m: m.link, together=True), key=lambda b: r.order.index(b["key"]))
    for block in forward:
        block["rotation"] = None if block["key"] in wide else rotations[block["key"]]
    return {
        "forward": forward, "backward": blocks(BACKWARD, lambda m: m.link),
        "composite": blocks(COMPOSITE, lambda m: m.link), "columns": blocks(COLUMNS, lambda m: m.column),
        "links": _kinematic_rows(derivation, index), "link_index": index,
    }


def recursion_context(derivation: Derivation, fmt: Any, plain: Any) -> dict[str, Any]:
    """What ``recursion.tex.j2`` shows (its variables are documented in docs/templates.md):
    ``recursion_parts`` in LaTeX. ``fmt`` formats the recursion (``latex.RecursionFormatter``),
    ``plain`` the robot's data (the sheet's formatter)."""
    robot, r, table = derivation.robot, derivation.recursion, derivation.symbols
    parts = recursion_parts(derivation, fmt.width)
    index = parts["link_index"]
    n = len(robot.coordinates)

    def shown(name: str, value: sympy.Expr, symbol: sympy.Symbol | None = None) -> dict[str, Any]:
        text = fmt.display(value, None, COLUMN_UNITS)
        return {"name": name, "value": text, "parts": text.lines, "symbol": symbol}

    def line(item: dict[str, Any]) -> dict[str, Any]:
        if item["symbol"] is not None:
            return shown(fmt(item["symbol"]), item["value"], item["symbol"])
        aliases = [shown(_name(a["meaning"], index, robot, n), a["value"]) for a in item["aliases"]]
        if len(aliases) == 1:
            return aliases[0]
        text = ",\\quad ".join(f"{a['name']} = {a['value']}" for a in aliases)
        return {"name": None, "symbol": None, "value": text, "parts": [text]}

    def latex(blocks: list[dict[str, Any]]) -> list[dict[str, Any]]:
        return [{"key": b["key"], "lines": [line(item) for item in b["lines"]],
                 "title": (f"Column {b['index']}" if b["link"] is None
                           else f"Link {b['index']} (\\texttt{{{escape_tex(b['link'])}}})"),
                 "rotation": None if b["rotation"] is None else f"R_{{{b['index']}}} = {fmt(b['rotation'])}"}
                for b in blocks]

    blocks = {key: latex(parts[key]) for key in ("forward", "backward", "composite", "columns")}

    def vector(values: list[sympy.Expr]) -> str:
        return "(" + ", ".join(plain(v) for v in values) + ")"

    return {
        "links": kinematic_table(parts["links"], robot.planar, plain, vector, escape_tex, ""),
        "coordinates": [{"index": k, "name": plain(q)} for k, q in enumerate(table.q, 1)],
        "mimics": [{"k": k, "i": i, "variable": fmt(v)} for k, i, v in mimic_variables(derivation)],
        **blocks,
        "tau": fmt(sympy.Matrix(r.tau).T),   # a row: the template transposes it
        "M_g": fmt.matrix("M", sympy.Matrix(n, n, [e for row in r.mass_matrix for e in row])),
        "lines": sum(len(b["lines"]) for part in blocks.values() for b in part),
    }


def kinematic_table(rows: list[dict[str, Any]], planar: bool, plain: Any, vector: Any, text: Any,
                    absent: Any) -> list[dict[str, Any]]:
    """The kinematic data (``_kinematic_rows``) as a sheet shows them: values by ``plain``, lists
    by ``vector``, names by ``text``, ``absent`` for a fixed joint's coordinate and axis."""
    return [{
        "index": row["index"], "name": text(row["name"]), "joint": text(row["joint"]),
        "type": row["type"], "parent": row["parent"],
        "coordinate": plain(row["coordinate"]) if row["coordinate"] is not None else absent,
        "xyz": vector(row["xyz"]), "rpy": vector(row["rpy"]),
        "axis": vector(row["axis"]) if row["axis"] else absent,
        "mass": plain(row["mass"]), "com": vector(row["com"]),
        "inertia": plain(row["inertia"][0]) if planar else vector(row["inertia"]),
    } for row in rows]


#: Estimated width (math glyphs) of values shown as they are that share one display line.
ALIAS_UNITS = 30


def _group_aliases(lines: list[dict[str, Any]], width: Any) -> list[dict[str, Any]]:
    """Consecutive values shown as they are (``\\omega_{2z} = \\dot q_2``) in groups
    (``symbol`` None, ``aliases``) that fit side by side in ALIAS_UNITS, each taking its
    value's width and 4 more (the name, the sign)."""
    grouped: list[dict[str, Any]] = []
    used = 0.0
    for item in lines:
        if item["symbol"] is not None:
            grouped.append(item)
            used = 0.0
            continue
        extent = width(item["value"]) + 4
        if grouped and grouped[-1]["symbol"] is None and used + extent <= ALIAS_UNITS:
            grouped[-1]["aliases"].append(item)
            used += extent
        else:
            grouped.append({"symbol": None, "aliases": [item]})
            used = extent
    return grouped


def _rotation(link: str, r: Any) -> sympy.Matrix | None:
    """``R_i``, the matrix of its entries (names where they are lines), None if it is 1."""
    entries = {m.index: v for m, v in r.program.records if m.quantity == "R" and m.link == link}
    matrix = sympy.Matrix(3, 3, lambda a, b: entries.get((a, b), 0))
    return None if matrix == sympy.eye(3) else matrix


def _matrix_width(matrix: sympy.Matrix, width: Any) -> float:
    """Estimated width of ``matrix`` typeset whole (widest entry per column, gaps, name)."""
    return sum(max(width(matrix[i, j]) for i in range(3)) for j in range(3)) + 10.0


def _kinematic_rows(derivation: Derivation, index: dict[str, int]) -> list[dict[str, Any]]:
    """Per link, as the robot file gives them (names as written, values as SymPy): ``index``,
    ``name``, ``joint`` (its name), ``type``, ``parent`` (the parent's index), ``coordinate``
    (or None for a fixed joint), the origin's offset ``xyz`` and angles ``rpy``, ``axis`` (or
    None), ``mass``, centre of mass ``com`` and ``inertia`` about it (six values; planar: the
    one planar motion reads first)."""
    robot, table = derivation.robot, derivation.symbols
    rows = []
    for link in robot.links:
        joint = robot.parent_joint(link.name)
        origin = list(joint.origin)
        xyz, rpy = (origin[:2] + [0], [0, 0, origin[2] if len(origin) > 2 else 0]) if robot.planar else (origin[:3], origin[3:])
        axis = list(joint.axis)
        if robot.planar:   # the plane z = 0 of a 3-D model: revolute about z, prismatic in the plane
            axis = [0, 0, 1] if joint.kind.angle else axis[:2] + [0]
        rows.append({
            "index": index[link.name], "name": link.name, "joint": joint.name, "type": joint.type,
            "parent": index[joint.parent],
            "coordinate": joint_variable(robot, table, joint) if joint.moves else None,
            "xyz": [table.expr(v) for v in xyz], "rpy": [table.expr(v) for v in rpy],
            "axis": [table.expr(v) for v in axis] if joint.moves else None,
            "mass": table.expr(link.mass), "com": [table.expr(v) for v in link.com],
            "inertia": [table.expr(v) for v in link.inertia],
        })
    return rows


def joint_variable(robot: Robot, table: Any, joint: Any) -> sympy.Expr:
    """A moving joint's variable: its coordinate (a floating or spherical joint's name), or
    ``multiplier * q_leader + offset`` for a <mimic> joint."""
    leader, multiplier, offset = robot.driver(joint)
    return table.expr(multiplier) * sympy.Symbol(leader) + table.expr(offset)
