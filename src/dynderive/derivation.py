"""``Derivation``: every named quantity of a robot's equations of motion, the straight-line
programs of the recursive algorithms, and the checks.

The engine's only output. Renderers read it; they never call into ``mechanics`` themselves.
"""

from __future__ import annotations

from collections.abc import Callable, Collection, Iterator
from dataclasses import dataclass
from functools import cached_property
from typing import TYPE_CHECKING, Any, cast

import sympy

from .mechanics import joint_types
from .mechanics.consistency import run_checks
from .mechanics.module_programs import build_programs
from .mechanics.planar import PlanarLinkKinematics, planar_kinematics
from .mechanics.polynomial import expand
from .mechanics.program import Program, lines_read
from .mechanics.recursive import GeneralizedProgram
from .mechanics.regularity import check_mass_matrix
from .mechanics.tidy import Check, fold_constants, is_small, quick_tidy, tidy
from .model.naming import (
    CENTROIDAL_QUANTITIES,
    LOOP_KEYS,
    MAXIMAL_EQUATION_KEYS,
    MAXIMAL_MODEL_KEYS,
    QUANTITY_DESCRIPTIONS,
    body_jacobian_index,
    frame_quantity_names,
)
from .model.robot import Joint, Robot
from .model.symbols import SymbolTable
from .stages import LazyMapping, Stage, Stages

if TYPE_CHECKING:
    from .mechanics.centroidal_programs import CentroidalPrograms
    from .mechanics.centroidal_steps import CentroidalSteps
    from .mechanics.contact_program import ContactPrograms
    from .mechanics.drives import JointDrive
    from .mechanics.frames import FramePrograms
    from .mechanics.generalized import GeneralizedSteps
    from .mechanics.joint_types import ConfigurationProgram
    from .mechanics.loop_programs import LoopLinearization, LoopPrograms
    from .mechanics.loops import LoopModel
    from .mechanics.maximal import MaximalSteps
    from .mechanics.quasi_velocity import QuasiVelocitySteps
    from .mechanics.regressor import Parameter
    from .mechanics.sheet_recursion import Recursion
    from .mechanics.spatial import SpatialLinkKinematics
    from .model.array_program import ArrayProgram

Progress = Callable[[str], None]

#: What an output reads from a derivation (``derive``'s ``wants``): "sheet", the symbolic
#: quantities, their steps and the checks (the worked sheet, the JSON, the terminal, MATLAB's
#: script); "code", the programs every code target prints; "kinematics", the links' symbolic
#: kinematics (MATLAB's script of a large robot).
WANTS = ("sheet", "code", "kinematics")


@dataclass
class StageResults:
    """What the stages derive beside the named quantities, typed; read through ``Derivation``'s
    accessors, which run the stage first (``link_kinematics``, ``loop_model``,
    ``generalized_steps``, ``maximal_steps``)."""

    kinematics: list[PlanarLinkKinematics | SpatialLinkKinematics] | None = None
    loops: LoopModel | LoopPrograms | None = None
    generalized: GeneralizedSteps | None = None
    maximal_model: MaximalSteps | None = None
    maximal: MaximalSteps | None = None


class Derivation:
    """Named SymPy quantities (DESIGN.md section 4), intermediate steps and checks, each
    derived when first asked for: code for a 3-D arm needs none of the symbolic matrices.

    >>> d = derive(load_robot("rp_arm"))          # doctest: +SKIP
    >>> d["N_g"]                                   # doctest: +SKIP
    Matrix([[g*m*(l + q2)*cos(q1)], [g*m*sin(q1)]])

    Large robots (``mechanics.structured.intermediate_form``) hold M_g ... EOM_g2 and the body
    Jacobians over sub-expressions ``_w1, _w2, ...`` that ``intermediates`` defines in order.
    """

    def __init__(self, robot: Robot, symbols: SymbolTable, progress: Progress | None = None):
        from .mechanics.structured import intermediate_form

        self.robot, self.symbols = robot, symbols
        self.report: Progress = progress or (lambda stage: None)
        #: Remarks about the derivation (dropped redundant loop rows, singular partitions).
        self.notes: list[str] = []
        #: Whether the generalized quantities are in intermediate-variable form (large robots).
        self.intermediate_form = intermediate_form(robot)
        self._stages = Stages()
        self.quantities = LazyMapping(self._stages)
        self._results = StageResults()
        self._checks: list[Check] | None = None
        add = self._stages.add
        add(Stage(self._kinematics, frozenset()))
        add(Stage(self._applied_forces, frozenset({"Y_g"})))
        if robot.loops:
            add(Stage(self._loops, frozenset() if robot.floating else frozenset(LOOP_KEYS)))
        add(Stage(self._generalized, None))
        if robot.planar:
            add(Stage(self._maximal_model, frozenset(MAXIMAL_MODEL_KEYS)))
            add(Stage(self._maximal_equations, frozenset(MAXIMAL_EQUATION_KEYS)))
        if robot.frames and not self.intermediate_form:
            names = (name for f in robot.frames for name in frame_quantity_names(f.name, robot.planar))
            add(Stage(self._frames, frozenset(names)))
        if not robot.planar and not robot.floating and not robot.loops and not self.intermediate_form:
            add(Stage(self._centroidal, frozenset(CENTROIDAL_QUANTITIES)))

    def prepare(self, wants: Collection[str]) -> None:
        """Derive now what the outputs ``wants`` (``WANTS``) read, so that rendering them derives
        nothing: the derivation's progress, its errors and its time are ``derive``'s."""
        if unknown := set(wants) - set(WANTS):
            raise ValueError(f"unknown wants {sorted(unknown)}: expected some of {', '.join(WANTS)}")
        robot = self.robot
        if "sheet" in wants:
            if robot.floating:   # quasi-velocities: the sheet of a robot with quaternion joints
                _ = self.quasi_velocity_steps, self.centroidal_steps
            else:
                _ = len(self.quantities), self.checks, self.centroidal_steps
                if self.intermediate_form:   # a large robot's sheet shows its recursion
                    _ = self.recursion
        if "code" in wants:
            _ = (self.programs, self.effort_jacobian, self.frame_programs, self.centroidal_programs,
                 self.configuration_programs, self.contact_programs, self.loop_solve)
            if robot.loops:
                _ = self.loop_linearization_programs if robot.floating else self.loop_linearization
            if not self.structured_code:   # a small planar robot's code prints M_g, C_g, N_g
                _ = self.quantities["M_g"]
            if robot.planar:   # the maximal-coordinate functions
                self._stages.run(self._maximal_model)
        if "kinematics" in wants and not robot.floating:
            _ = self.link_kinematics

    # -- stages ----------------------------------------------------------------------------
    def _symbolic(self, what: str) -> None:
        """Refuse the symbolic derivation (Lagrange's path) of a floating-base robot: its
        quaternion coordinates are not generalized coordinates of that path."""
        if self.robot.floating:
            from .mechanics.tree import not_built

            raise not_built(self.robot, what)

    def _kinematics(self) -> None:
        self._symbolic("the symbolic kinematics")
        self.report(f"kinematics ({len(self.robot.links)} links)")
        if self.robot.planar:
            self._results.kinematics = list(planar_kinematics(self.robot, self.symbols))
        else:
            from .mechanics.spatial import spatial_kinematics

            self._results.kinematics = list(spatial_kinematics(self.robot, self.symbols))

    def _applied_forces(self) -> None:
        self._symbolic("the symbolic applied forces Y_g")
        from .mechanics.generalized import applied_forces

        self.quantities["Y_g"] = applied_forces(self.robot, self.symbols)

    def _generalized(self) -> None:
        self._symbolic("the symbolic equations of motion (M_g, C_g, N_g, Lagrange's equations)")
        robot, table = self.robot, self.symbols
        if self.intermediate_form:
            from .mechanics.structured import structured_generalized

            self.report(f"generalized quantities in intermediate-variable form ({len(robot.coordinates)} coordinates)")
            quantities, steps = structured_generalized(robot, table, self.generalized_program, self.report)
        else:
            from .mechanics.generalized import derive_generalized

            self.report("energies")
            quantities, steps = derive_generalized(robot, table, self.link_kinematics, self.report)
        if robot.loops:
            self._close_loops(quantities)
        self.quantities.update(quantities)
        self._results.generalized = steps

    def _loops(self) -> None:
        if self.robot.floating:   # quaternions in q: the loops are rows on the tree's twists
            from .mechanics.loop_programs import open_tree_note

            self._results.loops = self.loop_programs
            self.notes.append(open_tree_note(self.robot, self.loop_programs))
            return
        from .mechanics.loops import derive_loops

        self.report("loop constraints")
        model = derive_loops(self.robot, self.symbols, self.link_kinematics)
        self.symbols.loop_multipliers = model.multipliers
        self.quantities.update(zip(LOOP_KEYS, (model.constraints, model.jacobian, model.jacobian_dot,
                                                sympy.Matrix(model.multipliers))))
        self._results.loops = model
        self.notes.extend(model.notes)

    @property
    def mobility(self) -> int:
        """Degrees of freedom: the coordinates less the independent loop constraints (none recorded
        for loops on a robot with quaternions in q: their rank is found per state)."""
        if self.robot.loops and self.robot.floating:
            raise ValueError("the mobility of loops on a floating base or with spherical joints is not recorded: "
                             "the rank of loop_jacobian(q) is found per state by the generated module")
        return self.loop_model.mobility if self.robot.loops else len(self.robot.coordinates)

    def _loop_force(self) -> sympy.Matrix:
        return self.quantities["A_g"].T * self.quantities["lambda_g"]

    def _close_loops(self, q: dict[str, Any]) -> None:
        """The multiplier form ``- A_g^T lambda_g`` joins EOM_g1 and EOM_g2 of the generalized
        quantities ``q``; the reduced form on the independent coordinates where it stays
        readable (``mechanics/loops.py``)."""
        from .mechanics.loops import reduced_form

        force = self._loop_force()
        clean = expand if self.intermediate_form else tidy
        for key in [k for k in ("EOM_g1", "EOM_g2") if k in q]:   # EOM_g1: where Lagrange's route ran
            q[key] = (q[key] - force).applyfunc(clean)
        if not self.intermediate_form:
            q.update(reduced_form(self.loop_model, self.symbols, q["M_g"], q["C_g"], q["N_g"], q["Y_g"]))

    def _maximal_model(self) -> None:
        from .mechanics.drives import drive_terms
        from .mechanics.maximal import maximal_model

        robot, table = self.robot, self.symbols
        links = cast("list[PlanarLinkKinematics]", self.link_kinematics)
        loops = self.loop_model if robot.loops else None
        self.report(f"maximal coordinates: model ({3 * len(robot.links)} coordinates)")
        gravity = sympy.Matrix([table.expr(e) for e in robot.gravity])
        quantities, steps = maximal_model(robot, table, links, gravity, drive_terms(robot, table),
                                          loops.row_indices if loops else None,
                                          quick_tidy if self.intermediate_form else tidy)
        self.quantities.update(quantities)
        self._results.maximal_model = steps

    def _maximal_equations(self) -> None:
        from .mechanics.maximal import maximal_equations

        self._stages.run(self._maximal_model)
        model = {key: self.quantities[key] for key in MAXIMAL_MODEL_KEYS if key in self.quantities}
        steps = cast("MaximalSteps", dict(self._results.maximal_model or {}))
        self.report("maximal coordinates: equations of motion")
        quantities = maximal_equations(self.symbols, model, steps,
                                       self._loop_force() if self.robot.loops else None,
                                       change_of_basis=not self.intermediate_form,
                                       clean=quick_tidy if self.intermediate_form else tidy)
        self.quantities.update(quantities)
        self._results.maximal = steps

    def _frames(self) -> None:
        from .mechanics.frames import frame_quantities

        self._symbolic("the frames' quantities")
        self.report(f"frames ({len(self.robot.frames)})")
        self.quantities.update(frame_quantities(self.robot, self.symbols))

    def _centroidal(self) -> None:
        steps = self.centroidal_steps
        if steps is not None:
            self.quantities.update(steps.quantities())

    @cached_property
    def centroidal_steps(self) -> CentroidalSteps | None:
        """A small 3-D robot's centre of mass and centroidal momentum matrix derived step by
        step (``mechanics.centroidal_steps.CentroidalSteps``: m_total, p_G, J_G, A_G) from the
        links' kinematics of its sheet (with quaternion joints, the quasi-velocity sheet's);
        None for a planar robot, a large one or one with loops (the generated code computes them),
        or one whose links all stay still."""
        from .mechanics.centroidal_steps import fixed_base_centroidal, moving_links, quasi_velocity_centroidal

        robot = self.robot
        if robot.planar or robot.loops or not moving_links(robot) or (self.intermediate_form and not robot.floating):
            return None   # with loops the tree's A_G is one step removed from the motion: in the code only
        sheet = self.quasi_velocity_steps.sheet if robot.floating else None
        if robot.floating and sheet is None:
            return None
        self.report("centre of mass and centroidal momentum")
        if sheet is not None:
            return quasi_velocity_centroidal(robot, self.symbols, sheet)
        return fixed_base_centroidal(robot, self.symbols, self.link_kinematics)

    # -- the stages' results, typed ---------------------------------------------------------
    @property
    def link_kinematics(self) -> list[PlanarLinkKinematics | SpatialLinkKinematics]:
        """The links' symbolic kinematics in the file's link order (``planar.PlanarLinkKinematics``
        or ``spatial.SpatialLinkKinematics``: poses, twists, body Jacobians), derived on first use;
        not for a robot with quaternions in q."""
        self._stages.run(self._kinematics)
        return cast("list[PlanarLinkKinematics | SpatialLinkKinematics]", self._results.kinematics)

    @property
    def loop_model(self) -> LoopModel:
        """The closed loops' symbolic model (``mechanics.loops.LoopModel``: the rows kept, their
        rank, the independent coordinates, the default assembly). A robot with quaternions in q
        has none: its loops are rows on the tree's twists, ``loop_programs``."""
        if not self.robot.loops or self.robot.floating:
            raise ValueError(f"{self.robot.name} has no symbolic loop model: "
                             + ("its loops are closed by loop_programs" if self.robot.loops else "no closed loops"))
        self._stages.run(self._loops)
        return cast("LoopModel", self._results.loops)

    @property
    def generalized_steps(self) -> GeneralizedSteps:
        """The generalized stage's steps (``mechanics.generalized.GeneralizedSteps``: the links'
        terms, Lagrange's derivatives, gravity, the drive terms), derived on first use."""
        self._stages.run(self._generalized)
        return cast("GeneralizedSteps", self._results.generalized)

    @property
    def maximal_steps(self) -> MaximalSteps | None:
        """The maximal stages' steps of a planar robot (``mechanics.maximal.MaximalSteps``: the
        constraints' origin, the bodies' Jacobians, Lagrange's derivatives, the change of basis),
        derived on first use; None for a 3-D robot, which has no maximal coordinates."""
        if not self.robot.planar:
            return None
        self._stages.run(self._maximal_equations)
        return cast("MaximalSteps", self._results.maximal)

    # -- results ---------------------------------------------------------------------------
    def description(self, name: str) -> str:
        """What quantity ``name`` is (empty if it has no description)."""
        from .mechanics.frames import describe

        index = body_jacobian_index(name, len(self.robot.links))
        if index is not None:   # frames may not be named so (input/names.py)
            rows = "(v_x, v_y, omega)" if self.robot.planar else "(v, omega)"
            return (f"body Jacobian of link {index} ({self.robot.links[index - 1].name}): the twist of its centre "
                    f"of mass in the link's own axes per joint rate, rows {rows}")
        from .mechanics.centroidal_steps import DESCRIPTIONS as CENTROIDAL

        return QUANTITY_DESCRIPTIONS.get(name) or CENTROIDAL.get(name) or describe(name) or ""

    @cached_property
    def frame_programs(self) -> list[FramePrograms]:
        """Straight-line programs of the frames' poses, Jacobians and ``Jdot qd``
        (``mechanics.frames.FramePrograms``, also a tuple ``(name, transform, jacobian,
        jacobian_dot_qd)``), for the generated module; built on first use."""
        from .mechanics.frames import frame_programs

        if self.robot.frames:
            self.report(f"program: frames ({len(self.robot.frames)})")
        return frame_programs(self.robot, self.symbols)

    @cached_property
    def loop_programs(self) -> LoopPrograms:
        """Straight-line programs of the loops' residual, Jacobian on the velocities and ``Jdot qd``
        (``mechanics.loop_programs.LoopPrograms``: the loops as rows on the tree's twists), for a
        robot with quaternions in ``q``, whose loops have no symbolic route; built on first use."""
        from .mechanics.loop_programs import loop_programs

        self.report(f"program: loop constraints ({len(self.robot.loops)} loop joints)")
        return loop_programs(self.robot, self.symbols)

    @cached_property
    def loop_linearization_programs(self) -> LoopLinearization:
        """The loops' terms of ``linearize`` for a robot with quaternions in ``q``
        (``mechanics.loop_programs.LoopLinearization``, on the tangent space); the other loop
        robots' are symbolic (``loop_linearization``)."""
        from .mechanics.loop_programs import loop_linearization_programs

        self.report("program: the loops' derivatives (linearize)")
        return loop_linearization_programs(self.robot, self.symbols)

    @cached_property
    def contact_programs(self) -> ContactPrograms | None:
        """The programs of ``constrained_forward_dynamics`` and ``impulse_dynamics``
        (``mechanics.contact_program.ContactPrograms``) every target prints, for a 3-D robot
        (its closed loops' rows solved with the contacts'); None for a planar one."""
        from .mechanics.contact_program import contact_programs

        if self.robot.planar:
            return None
        return contact_programs(len(self.symbols.qd), self.robot.floating, self.loop_rows)

    @cached_property
    def loop_solve(self) -> ArrayProgram | None:
        """The program of the loops' constrained solve (``mechanics.loop_solve``) every target
        prints for a robot with closed loops; None for the others."""
        from .mechanics.loop_solve import loop_solve_program

        if not self.robot.loops:
            return None
        return loop_solve_program(len(self.symbols.qd), *self.loop_rows, bool(self.robot.floating))

    @property
    def loop_rows(self) -> tuple[int, int | None] | None:
        """The closed loops' rows k and their rank (None: found at each state, a robot with
        quaternions in q), or None without loops."""
        if not self.robot.loops:
            return None
        if self.robot.floating:
            return len(self.loop_programs.rows), None
        return self.quantities["a_g"].shape[0], self.loop_model.rank

    @cached_property
    def effort_jacobian(self) -> sympy.Matrix:
        """dY/du (NV x NU): each effort's generalized force per unit effort, which linearize's
        input matrix B and the compiled targets print; with quaternions (efforts acting at
        their velocity columns) a 1 at each effort's column."""
        efforts = list(self.symbols.efforts.values())
        if not efforts:
            return sympy.zeros(len(self.symbols.qd), 0)
        if len(self.symbols.q) != len(self.symbols.qd):
            columns = self.robot.effort_columns()
            return sympy.Matrix(len(self.symbols.qd), len(efforts), lambda i, k: int(columns[k] == i))
        return self.quantities["Y_g"].jacobian(sympy.Matrix(efforts))

    @cached_property
    def centroidal_programs(self) -> CentroidalPrograms | None:
        """Straight-line programs of the centre of mass and the centroidal momentum
        (``mechanics.centroidal_programs.CentroidalPrograms``) of a 3-D robot, None for a planar one;
        built on first use."""
        from .mechanics.centroidal_programs import centroidal_programs

        if self.robot.planar:
            return None
        self.report("program: centre of mass and centroidal momentum")
        return centroidal_programs(self.robot, self.symbols)

    @property
    def intermediates(self) -> list[tuple[sympy.Symbol, sympy.Expr]]:
        """``(name, definition)`` of the intermediate variables, in order (large robots; else
        empty): each definition uses coordinates, parameters and earlier names only."""
        if not self.intermediate_form:
            return []
        return list(self.generalized_steps["intermediates"])

    def lambdify(self, args: list[Any], value: Any) -> Callable[..., Any]:
        """``sympy.lambdify(args, value)`` (NumPy) for a quantity of this derivation; for a
        large robot the intermediate variables are computed first, in order, as its lines."""
        value = fold_constants(value)
        if not self.intermediate_form:
            return sympy.lambdify(args, value, modules="numpy", cse=True)
        # only the intermediates the value reads (printing all of a 12-joint chain's 2 500 costs seconds)
        needed = lines_read([value], dict(self.intermediates))
        lines = [(name, fold_constants(e)) for name, e in self.intermediates if name in needed]
        return sympy.lambdify(args, value, modules="numpy", cse=lambda exprs: (lines, exprs))

    @property
    def checks(self) -> list[Check]:
        """The engine's consistency checks (``run_checks``), run on first use."""
        if self._checks is None:
            self._checks = []
            self._stages.need(None)
            self.report("checks")
            self._checks = run_checks(self)
        return self._checks

    @property
    def checks_run(self) -> list[Check]:
        """The checks if an output already needed them (the sheet, the JSON), else none: a
        run that writes only code reports no checks rather than deriving everything for them."""
        return self._checks or []

    @cached_property
    def configuration_programs(self) -> dict[str, ConfigurationProgram]:
        """The configuration maps ``neutral_configuration``, ``integrate``, ``difference`` and
        ``configuration_rate`` as target-neutral programs, joint by joint from the joint types
        (``mechanics.joint_types.configuration_programs``); built on first use."""
        from .mechanics.joint_types import configuration_programs

        return configuration_programs(self.robot, self.symbols)

    @cached_property
    def quasi_velocity_steps(self) -> QuasiVelocitySteps:
        """A robot with quaternion joints: its sheet quantities in quasi-velocities
        (``mechanics.quasi_velocity.QuasiVelocitySteps``: step by step when small, Y, the
        joints' rotations), derived once on first use."""
        from .mechanics.quasi_velocity import quasi_velocity_steps

        return quasi_velocity_steps(self.robot, self.symbols)

    @cached_property
    def programs(self) -> dict[str, Program]:
        """Straight-line programs of the recursive algorithms over the robot's one tree
        (``mechanics/module_programs.py``), by what they compute: ``inverse_dynamics``,
        ``forward_dynamics``, ``regressor`` and ``inverse_dynamics_derivatives`` for every
        robot, and ``mass_matrix``, ``coriolis``, ``gravity``, ``potential`` where the code is
        structured (``structured_code``). Built once, on first use, straight from the robot: a
        run that writes only code never derives the symbolic matrices."""
        generalized = (lambda: self.generalized_program) if self.structured_code else None
        return build_programs(self.robot, self.symbols, generalized, self.report)

    @cached_property
    def loop_linearization(self) -> tuple[sympy.Matrix, sympy.Matrix]:
        """What ``linearize`` of a closed-loop robot needs beyond Newton-Euler's derivatives
        (``mechanics.linearization.loop_linearization_terms``: ``d(A_g^T lambda_g)/dq`` and
        ``d(A_g qdd + Adot_g qd)/dq``), built once for every code target."""
        from .mechanics.linearization import loop_linearization_terms

        return loop_linearization_terms(self.quantities, self.symbols)

    @cached_property
    def generalized_program(self) -> GeneralizedProgram:
        """The one straight-line program of M, C, N and V (``recursive.GeneralizedProgram``)
        that both the generated module and the intermediate-variable form read, built on first
        use."""
        self._symbolic("the generalized program (M, C, N, V)")
        return GeneralizedProgram(self.robot, self.symbols, self.report)

    @cached_property
    def recursion(self) -> Recursion:
        """Newton-Euler and CRBA as one program whose lines record their meaning
        (``mechanics.sheet_recursion.Recursion``), for a large robot's sheet; built on first use."""
        from .mechanics.sheet_recursion import newton_euler_recursion

        self._symbolic("the recursion of the sheet")
        return newton_euler_recursion(self.robot, self.symbols)

    @staticmethod
    def joint_type(joint: Joint) -> joint_types.JointType:
        """The joint's type (``mechanics.joint_types``): its placement for a figure's numbers."""
        return joint_types.of(joint)

    @staticmethod
    def joint_geometry(joint: Joint, expr: Callable[[object], sympy.Expr]) -> joint_types.Geometry:
        """The values of the joint's own keys (a helical joint's pitch) as ``expr`` reads them."""
        return joint_types.geometry_of(joint, expr)

    @property
    def parameter_vector(self) -> list[Parameter]:
        """The regressor's parameters ``pi`` (``mechanics.regressor.Parameter``: name, value
        over the robot's parameters), in the order of ``programs["regressor"]``'s columns."""
        from .mechanics.regressor import parameter_vector

        return parameter_vector(self.robot, self.symbols)

    @property
    def joint_drives(self) -> list[JointDrive]:
        """The velocity columns with drive terms (``mechanics.drives.JointDrive``), from the robot."""
        from .mechanics.drives import joint_drives

        return joint_drives(self.robot, self.symbols)

    @property
    def structured_code(self) -> bool:
        """Whether the generated module computes M, C, N, V by programs (3-D robots, large
        planar ones) rather than from the explicit quantities (small planar robots)."""
        return not self.robot.planar or self.intermediate_form

    def keys(self) -> list[str]:
        """The names of the quantities, in derivation order (``d.keys()``, as for a dict)."""
        return list(self.quantities)

    def _repr_latex_(self) -> str:
        """The equations of motion in a notebook: the manipulator form, and M, C, N where they
        are short enough to read."""
        names = self.symbols.latex_names()
        parts = [r"M(q)\,\ddot q + C(q, \dot q)\,\dot q + N(q) = \Upsilon"]
        for label, key in (("M", "M_g"), ("C", "C_g"), ("N", "N_g")):
            value = self.quantities[key]
            if is_small(sympy.Tuple(*value), 60 * len(value)) and not self.intermediate_form:
                parts.append(f"{label} = " + sympy.latex(value, symbol_names=names, mat_delim="["))
            else:
                parts.append(rf"{label}:\ \text{{{value.shape[0]} $\times$ {value.shape[1]}, too large to show}}")
        return rf"$\displaystyle \text{{{_latex_text(self.robot.title)}}}:\quad " + r",\quad ".join(parts) + "$"

    def __getitem__(self, name: str) -> Any:
        try:
            return self.quantities[name]
        except KeyError:
            raise KeyError(f"no quantity {name!r}; available: {', '.join(self.quantities)}") from None

    def __contains__(self, name: object) -> bool:
        return name in self.quantities

    def __iter__(self) -> Iterator[str]:
        return iter(self.quantities)

    @property
    def all_checks_passed(self) -> bool:
        return all(c.passed for c in self.checks if not c.skipped)


def derive(robot: Robot, wants: Collection[str] = (), progress: Progress | None = None) -> Derivation:
    """The derivation of ``robot``: its inputs are checked now (a singular mass matrix, loops
    that do not close), and what ``wants`` read (``WANTS``: "sheet", "code") is derived now,
    so a renderer only prints; anything else is derived on first use (``Derivation``)."""
    table = SymbolTable.for_robot(robot)
    check_mass_matrix(robot, table)
    derivation = Derivation(robot, table, progress)
    derivation._stages.run(derivation._loops)   # loop problems are input errors: at once
    derivation.prepare(wants)
    return derivation


def _latex_text(text: str) -> str:
    """Free text inside ``\\text{}`` (a notebook cell): LaTeX specials written literally."""
    specials = {"\\": r"\textbackslash{}", "{": r"\{", "}": r"\}", "&": r"\&", "#": r"\#", "%": r"\%", "$": r"\$",
                "_": r"\_", "^": r"\^{}", "~": r"\~{}"}
    return "".join(specials.get(c, c) for c in text if c.isprintable())
