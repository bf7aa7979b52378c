"""The SymPy symbols of a robot, named as DESIGN.md section 3 fixes them.

Every symbol is a plain ``sympy.Symbol`` (no assumptions), so the ``sympy`` strings of the
JSON dump parse back to equal expressions with ``sympy.sympify(text, locals=...)``.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import sympy

from .expressions import parse_expression
from .naming import acceleration_name, latex_name, maximal_coordinate_names, velocity_name
from .robot import Robot, floating_names


@dataclass
class SymbolTable:
    """All symbols of one robot: parameters, coordinates and their rates, efforts."""

    parameters: dict[str, sympy.Symbol]
    q: list[sympy.Symbol]
    qd: list[sympy.Symbol]
    qdd: list[sympy.Symbol]
    efforts: dict[str, sympy.Symbol]
    qm: list[sympy.Symbol] = field(default_factory=list)
    qmd: list[sympy.Symbol] = field(default_factory=list)
    qmdd: list[sympy.Symbol] = field(default_factory=list)
    multipliers: list[sympy.Symbol] = field(default_factory=list)
    #: Multipliers of the loop constraints (robots with loops): lambda_g1, lambda_g2, ...
    loop_multipliers: list[sympy.Symbol] = field(default_factory=list)
    #: Intermediate variables of a large robot's quantities (``_w1, _w2, ...``): names of
    #: sub-expressions, not free symbols, so not in ``all_symbols``; in ``locals`` for parsing.
    intermediates: list[sympy.Symbol] = field(default_factory=list)

    @classmethod
    def for_robot(cls, robot: Robot) -> SymbolTable:
        q: list[sympy.Symbol] = []
        qd: list[sympy.Symbol] = []
        qdd: list[sympy.Symbol] = []
        for joint in (j for j in robot.joints if j.owns):   # NQ coordinates, NV rates (DESIGN.md section 10)
            name = joint.name
            entries = joint.kind.names(name)[0]   # one per coordinate: a universal joint's two
            names = floating_names(name, joint.type) if joint.multi else (
                list(entries), [velocity_name(n) for n in entries], [acceleration_name(n) for n in entries])
            for kept, entries in zip((q, qd, qdd), names):
                kept += [sympy.Symbol(n) for n in entries]
        table = cls(parameters={p.name: sympy.Symbol(p.name) for p in robot.parameters}, q=q, qd=qd, qdd=qdd,
                    efforts={e: sympy.Symbol(e) for e in robot.efforts})
        if robot.planar:
            names = maximal_coordinate_names(len(robot.links))
            table.qm = [sympy.Symbol(n) for n in names]
            table.qmd = [sympy.Symbol(velocity_name(n)) for n in names]
            table.qmdd = [sympy.Symbol(acceleration_name(n)) for n in names]
        return table

    def expr(self, text: object) -> sympy.Expr:
        """Parse an (already validated) expression over the parameters."""
        return parse_expression(text, self.parameters)

    def maximal_expr(self, text: object) -> sympy.Expr:
        return parse_expression(text, dict(self.parameters) | {str(s): s for s in self.qm})

    def all_symbols(self) -> list[sympy.Symbol]:
        return [*self.parameters.values(), *self.q, *self.qd, *self.qdd, *self.efforts.values(),
                *self.qm, *self.qmd, *self.qmdd, *self.multipliers, *self.loop_multipliers]

    def latex_names(self) -> dict[sympy.Symbol, str]:
        names = {s: latex_name(str(s)) for s in self.all_symbols()}
        for coords, rates, accels in ((self.q, self.qd, self.qdd), (self.qm, self.qmd, self.qmdd)):
            for c, r, a in zip(coords, rates, accels):
                names[r] = latex_name(str(c), 1)
                names[a] = latex_name(str(c), 2)
        return names

    def defaults(self, robot: Robot) -> dict[sympy.Symbol, float]:
        """Parameter symbol -> default value, for the parameters that have one."""
        return {self.parameters[p.name]: p.value for p in robot.parameters if p.value is not None}

    def locals(self) -> dict[str, sympy.Symbol]:
        """Name -> symbol, for ``sympy.sympify(text, locals=table.locals())``."""
        return {str(s): s for s in [*self.all_symbols(), *self.intermediates]}
