"""CasADi's external-function ABI for the C target: ``<name>_casadi_forward_dynamics`` and
``<name>_casadi_inverse_dynamics``, written at the end of ``<name>_dynamics.c`` inside
``#ifdef <NAME>_CASADI_EXTERNAL`` (so the file stays plain C99 with only ``<math.h>`` unless
asked), each with the functions CasADi's ``external`` looks up beside it (``_n_in``,
``_sparsity_in``, ``_work``, ...) and, where the configuration has a coordinate per velocity
(no quaternion), its Jacobian ``jac_<function>`` from the derivative programs
(``forward_dynamics_derivatives``, ``inverse_dynamics_derivatives`` and the mass matrix), so
``casadi.external(name, "lib.so")`` can be differentiated, mapped and used in ``nlpsol`` with
no finite differences.

The parameters are the robot file's defaults (``p == NULL``): a Jacobian must cover every
input, and the programs have no derivative with respect to the parameters. CasADi's matrices
are column-major, the generated C's row-major, so each Jacobian block is transposed through
the work vector ``w``; a NULL input is zero and a NULL output is not wanted (CasADi's rules).
"""

from __future__ import annotations

from dataclasses import dataclass

from ....derivation import Derivation


@dataclass(frozen=True)
class Entry:
    """One CasADi external function: the C function it calls and its signature."""

    function: str            # forward_dynamics, inverse_dynamics
    inputs: tuple[str, ...]  # names, as the CasADi target's Function
    output: str
    blocks: tuple[str, ...]  # the Jacobian's blocks in input order: names of the derivative outputs


ENTRIES = (
    Entry("forward_dynamics", ("q", "qd", "u"), "qdd", ("dqdd_dq", "dqdd_dqd", "dqdd_du")),
    Entry("inverse_dynamics", ("q", "qd", "qdd"), "tau", ("dtau_dq", "dtau_dqd", "M")),
)


def external_section(derivation: Derivation) -> list[str]:
    """The guarded lines appended to ``<name>_dynamics.c``."""
    name = derivation.robot.name
    nq, nv, nu = len(derivation.symbols.q), len(derivation.symbols.qd), len(derivation.symbols.efforts)
    sizes = {"q": nq, "qd": nv, "qdd": nv, "u": nu, "tau": nv}
    jacobians = nq == nv
    macro = name.upper()
    lines = [
        f"#ifdef {macro}_CASADI_EXTERNAL",
        "/* CasADi's external-function ABI (compile with -D" + macro + "_CASADI_EXTERNAL into a shared",
        f"   library; casadi.external(\"{name}_casadi_forward_dynamics\", \"./lib{name}.so\")). The parameters",
        "   are the defaults. " + ("jac_<function> gives each Jacobian from the derivative programs. */"
                                  if jacobians else "No Jacobians: q holds quaternions (NQ != NV). */"),
        "#ifndef casadi_int",
        "#define casadi_int long long int",
        "#endif",
        "",
        f"static const double {name}_casadi_zeros[{max(nq, nv, nu, 1)}] = {{0.0}};",
    ]
    shapes = sorted({(sizes[i], 1) for e in ENTRIES for i in (*e.inputs, e.output)}
                    | ({(nv, sizes[i]) for e in ENTRIES for i in e.inputs} if jacobians else set()))
    for rows, columns in shapes:
        lines.append(f"static const casadi_int {_sparsity(name, rows, columns)}[3] = {{{rows}, {columns}, 1}};")
    for entry in ENTRIES:
        lines += _function(name, entry, sizes)
        if jacobians:
            lines += _jacobian(name, entry, sizes, nv)
    lines.append(f"#endif /* {macro}_CASADI_EXTERNAL */")
    return lines


def _sparsity(name: str, rows: int, columns: int) -> str:
    return f"{name}_casadi_dense_{rows}x{columns}"


def _function(name: str, entry: Entry, sizes: dict[str, int]) -> list[str]:
    symbol = f"{name}_casadi_{entry.function}"
    arguments = ", ".join([*entry.inputs, f"&{name}_default_parameters", "res[0]"])
    status = "return " if entry.function == "forward_dynamics" else ""
    return [
        "",
        f"/* {entry.function}({', '.join(entry.inputs)}) -> {entry.output}"
        + ("; returns 1 if M is not positive definite. */" if status else ". */"),
        f"int {symbol}(const double **arg, double **res, casadi_int *iw, double *w, int mem)",
        "{",
        *_inputs(name, entry.inputs),
        "    (void)iw; (void)w; (void)mem;",
        "    if (!res[0]) return 0;",
        f"    {status}{name}_{entry.function}({arguments});",
        *([] if status else ["    return 0;"]),
        "}",
        *_signature(symbol, name, [*((i, (sizes[i], 1)) for i in entry.inputs)],
                    [(entry.output, (sizes[entry.output], 1))], 0),
    ]


def _jacobian(name: str, entry: Entry, sizes: dict[str, int], nv: int) -> list[str]:
    """``jac_<symbol>``: inputs, then the nominal output (unused); a dense block per input."""
    symbol = f"jac_{name}_casadi_{entry.function}"
    widths = [sizes[i] for i in entry.inputs]
    offsets = [sum(nv * w for w in widths[:k]) for k in range(len(widths))]
    blocks = [f"w + {offset}" if offset else "w" for offset in offsets]
    if entry.function == "forward_dynamics":
        compute = [f"    if ({name}_forward_dynamics_derivatives(q, qd, u, &{name}_default_parameters, {', '.join(blocks)})) return 1;"]
    else:
        compute = [f"    {name}_inverse_dynamics_derivatives(q, qd, qdd, &{name}_default_parameters, {blocks[0]}, {blocks[1]});",
                   f"    {name}_mass_matrix(q, &{name}_default_parameters, {blocks[2]});"]
    transpose = []
    for k, width in enumerate(widths):
        transpose += [f"    if (res[{k}]) for (i = 0; i < {nv}; ++i) for (j = 0; j < {width}; ++j)",
                      f"        res[{k}][j * {nv} + i] = w[{offsets[k]} + i * {width} + j];"]
    output = entry.output
    return [
        "",
        f"/* d{output}/d({', '.join(entry.inputs)}) of {entry.function}, column-major {nv}-row blocks. */",
        f"int {symbol}(const double **arg, double **res, casadi_int *iw, double *w, int mem)",
        "{",
        "    int i, j;",
        *_inputs(name, entry.inputs),
        "    (void)iw; (void)mem;",
        *compute,
        *transpose,
        "    return 0;",
        "}",
        *_signature(symbol, name, [*((i, (sizes[i], 1)) for i in entry.inputs), (f"out_{output}", (nv, 1))],
                    [(f"jac_{output}_{i}", (nv, sizes[i])) for i in entry.inputs], nv * sum(widths)),
    ]


def _inputs(name: str, inputs: tuple[str, ...]) -> list[str]:
    return [f"    const double *{a} = arg[{k}] ? arg[{k}] : {name}_casadi_zeros;" for k, a in enumerate(inputs)]


def _signature(symbol: str, name: str, inputs: list[tuple[str, tuple[int, int]]],
               outputs: list[tuple[str, tuple[int, int]]], work: int) -> list[str]:
    """The functions CasADi's loader calls beside ``symbol``: counts, names, sparsities, work."""
    lines = [f"casadi_int {symbol}_n_in(void) {{ return {len(inputs)}; }}",
             f"casadi_int {symbol}_n_out(void) {{ return {len(outputs)}; }}"]
    for kind, items in (("in", inputs), ("out", outputs)):
        lines += [f"const char *{symbol}_name_{kind}(casadi_int i)", "{", "    switch (i) {",
                  *(f"    case {k}: return \"{n}\";" for k, (n, _) in enumerate(items)),
                  "    default: return 0;", "    }", "}",
                  f"const casadi_int *{symbol}_sparsity_{kind}(casadi_int i)", "{", "    switch (i) {",
                  *(f"    case {k}: return {_sparsity(name, *shape)};" for k, (_, shape) in enumerate(items)),
                  "    default: return 0;", "    }", "}"]
    lines += [f"int {symbol}_work(casadi_int *sz_arg, casadi_int *sz_res, casadi_int *sz_iw, casadi_int *sz_w)",
              "{",
              f"    if (sz_arg) *sz_arg = {len(inputs)};",
              f"    if (sz_res) *sz_res = {len(outputs)};",
              "    if (sz_iw) *sz_iw = 0;",
              f"    if (sz_w) *sz_w = {work};",
              "    return 0;",
              "}"]
    return lines
