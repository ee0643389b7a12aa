"""Kernel -> one standalone C99 file (runtime, linear algebra, model, one integrator, driver)."""
from __future__ import annotations

from fractions import Fraction

from .. import __version__
from ..escape import c_comment, c_string, csv_field
from ..frontend import units
from ..abi import summary_layout
from ..integrators import c_file, integrator_source, registry, standalone_source
from ..integrators.registry import OPTION_ORDER, OPTIONS
from ..tolerances import component_input, component_names
from . import GeneratedSource, template_environment
from .c_abi import runtime_contract, runtime_header, status_printer, summary_packer, verdict_printer
from .c_factor import factorisation_text
from .c_lanes import lane_groups
from .c_taylor_lanes import lane_series
from .c_taylor import series_context, series_text
from .kernel import JACOBIAN_ARRAYS, Block, Kernel, Loop, Store
from .printers import CPrinter, TaylorPrinter

# The parameters of each generated C function whose body is a kernel block.
# Where lanes.c takes the integrator's own lanes file.
LANES_METHOD = "/* LAG_LANES_METHOD */"
FUNCTION_PARAMETERS = {
    "initial": ("par", "y0"),
    "system": ("par", "t", "y", "K", "b"),
    "constant_mass": ("par", "K"),
    "jacobian": ("par", "t", "y", "acc", "lam", "Dq", "Dv", "Dz"),
    "momenta": ("par", "t", "y", "p"),
    "mass": ("par", "t", "y", "M"),
    "momentum_rate": ("par", "t", "y", "dp"),
    "constraint_rows": ("par", "t", "y", "g", "c", "A"),
    "outputs": ("par", "t", "y", "out", "inv"),
    "stop": ("par", "t", "y", "ev"),
    "parameter_jacobian": ("par", "t", "y", "acc", "lam", "Dp"),
    "output_jacobian": ("par", "t", "y", "lam", "Cy", "Cl", "Cp"),
    "initial_sensitivity": ("par", "S0"),
}


def render_c(kernel: Kernel, source_name: str = "model.lag", fmu: str | None = None,
             sensitivity: dict | None = None) -> GeneratedSource:
    """The scene's C file: with `fmu` (the FMU's variables and FMI functions, codegen/fmu.py) in place
    of the shared library's entry points and the standalone program; with `sensitivity` (the
    context of templates/c/sensitivity.c.j2, codegen/c_sensitivity.py) followed by the forward
    sensitivities' right-hand side, integrator and entry point."""
    return render_context(c_context(kernel, source_name, fmu is not None or sensitivity is not None), fmu, sensitivity)


def render_context(context: dict, fmu: str | None = None, sensitivity: dict | None = None) -> GeneratedSource:
    """The C file of a scene's `context` (c_context) with the part that takes the place of the
    shared library's entry points, if any (render_c)."""
    text = template_environment().get_template("c/model.c.j2").render({**context, "fmu": fmu, "sensitivity": sensitivity})
    return GeneratedSource("c", text, context["stem"])


def c_context(kernel: Kernel, source_name: str, elsewhere: bool) -> dict:
    """What the scene's C file says (its blocks printed), but for the part of an FMU or of the
    sensitivities (`elsewhere`: there is one): the printing is most of the cost, and an FMU's is
    the same in both FMI versions (lagdsl/fmu.py)."""
    printer = CPrinter()
    blocks = {name: _print_block(getattr(kernel, name), signature(kernel, name), kernel, printer)
              for name in FUNCTION_PARAMETERS if getattr(kernel, name) is not None}
    options = dict(kernel.integrator.options)
    method = registry.get(kernel.integrator.name)
    # taylor's statements, worked out once for the series and for its lanes (seconds for a large model)
    series = series_context(kernel, TaylorPrinter(), _k_positions(kernel)) if method.series else None
    lanes = _lanes(kernel, method, blocks, series, elsewhere)
    return {
        "title": f"{kernel.model_name}, scene {kernel.scene_name}: generated C simulation",
        "version": __version__, "source_name": source_name, "scene": kernel.scene_name,
        "stem": stem(kernel), "model": kernel.model_name, "integrator": kernel.integrator.name,
        "parameter_list": ", ".join(name for name, _ in kernel.parameters) or "none",
        "option_list": ", ".join(OPTIONS[k].flag for k in OPTION_ORDER if k in method.options),
        "runtime": runtime_header(), "linalg": _linear_algebra(kernel),
        "n": kernel.n, "size": kernel.size, "parameters": kernel.parameters,
        "columns": kernel.columns, "constraints": kernel.constraints, "holonomic": kernel.holonomic,
        "invariants": bool(kernel.invariant_names), "invariant_names": kernel.invariant_names,
        "parameter_names": [name for name, _ in kernel.parameters], "coordinates": kernel.coordinates,
        "csv_columns": [csv_field(column) for column in kernel.columns],
        "input_units": _input_unit_rows(kernel),
        "defaults": [f"par[{i}] = {_literal(value)};  /* {c_comment(name)} */"
                     for i, (name, value) in enumerate(kernel.parameters)],
        "derived": [f"if (!fixed[{i}])\n        par[{i}] = {printer.doprint(expr)};"
                    for i, expr in kernel.derived_parameters],
        "solver": kernel.solver, "jacobian": kernel.jacobian is not None, "implicit": method.implicit, "jac": kernel.jacobian_layout,
        "layout": layout_kind(kernel), "bandwidth": kernel.layout.bandwidth if kernel.layout else 0, "tree": kernel.layout, "stored": kernel.layout.size if kernel.layout else kernel.size ** 2,
        "factor": factorisation_text(kernel.layout),
        "canonical": kernel.momenta is not None,
        "outputs_need_multipliers": kernel.outputs_need_multipliers,
        "stop_needs_multipliers": kernel.stop_needs_multipliers,
        "integrator_source": integrator_source(kernel.integrator.name),
        "taylor_series": _series(series) if series is not None else "",
        "contract": runtime_contract(), "flags": _driver_flags(kernel, method, lanes), "lanes": lanes,
        "driver": c_file("forecast.c") + "\n" + c_file("driver.c"), "library": c_file("library.c"),
        "standalone": standalone_source(),
        "summary_packer": summary_packer(summary_layout(method.name, len(kernel.invariant_names), 2 * kernel.n,
                                                        bool(kernel.constraints), kernel.stop is not None)),
        "status_printer": status_printer(),
        "verdict_printer": verdict_printer() if method.stiffness_test else "",
        "t_start": _literal(kernel.time.start), "t_stop": _literal(kernel.time.stop),
        "t_interval": _literal(kernel.time.interval),
        "options_init": _options_initializer(options), "atol": _atol_tables(kernel) if "atol" in method.options else None,
        "option_fields": _option_fields(method.options),
        "stop_text": kernel.stop_text, "stop": None, "constant_mass": None,      # blocks a scene may not have (below)
        **_gram_tables(kernel),
        **blocks,
    }


def _series(series: dict) -> str:
    """Taylor's series of the model part (`series`: c_taylor.series_context), after its own sin and
    cos (taylor_functions.c)."""
    return c_file("taylor_functions.c") + "\n" + series_text(series)


def _k_positions(kernel: Kernel) -> list[str]:
    """The C indices of K's stores in the system block, in order (what the Taylor series assemble)."""
    return [_position(s, kernel) for s in kernel.system.stores if s.array == "K"]


def signature(kernel: Kernel, name: str) -> tuple[str, ...]:
    """The parameters of the function whose body is block `name`: with M apart (constant_mass),
    the system block is lag_forces(par, t, y, b)."""
    if name == "system" and kernel.constant_mass is not None:
        return ("par", "t", "y", "b")
    return FUNCTION_PARAMETERS[name]


def layout_kind(kernel: Kernel) -> str:
    """How the generated code stores and solves K: "diagonal", "sparse" or "dense" (structure.py)."""
    return kernel.layout.kind if kernel.layout else "dense"


def _lanes(kernel: Kernel, method: registry.Integrator, blocks: dict, series: dict | None,
           elsewhere: bool) -> dict | None:
    """The sweep's path in SIMD lanes (lanes.c with the integrator's lanes file in it; the right-hand
    side in lanes of c_lanes.py, or taylor's series in lanes of c_taylor_lanes.py), or None where the
    scene has none: an integrator without one, a program that is not the shared library's
    (`elsewhere`: an FMU, sensitivities), constraints, a stop condition, a system block with
    stencil loops (a large chain, whose loops over its members already vectorise), or a series
    that c_taylor_lanes.py does not write in lanes (`series`: taylor's c_taylor.series_context)."""
    system = kernel.system
    if (not method.lanes or elsewhere or kernel.constraints or kernel.stop is not None or system is None
            or system.loops or system.cleared or system.accumulators):
        return None
    source = c_file("lanes.c").replace(LANES_METHOD, c_file(method.lanes))
    if method.series:
        in_lanes = lane_series(series)
        return None if in_lanes is None else {"kept": (), "groups": (), "source": source, **in_lanes}
    kept, groups = lane_groups(system, blocks["system"])
    return {"kept": kept, "groups": groups, "series": "", "switch": 1, "source": source, "vectors": 1}


def _driver_flags(kernel: Kernel, method: registry.Integrator, lanes: dict | None) -> list[tuple[str, int | str, str]]:
    """The LAG_HAS_* switches of driver.c and standalone*.c: what this scene has (LAG_HAS_LANES may be
    a condition on the build's precision, c_taylor_lanes.py)."""
    return [("LAG_HAS_CONSTRAINTS", int(bool(kernel.constraints)), "project onto constraints, watch their residual"),
            ("LAG_HAS_INVARIANTS", int(bool(kernel.invariant_names)), "watch conserved quantities"),
            ("LAG_HAS_STOP", int(kernel.stop is not None), "a stop condition may end the run"),
            ("LAG_HAS_STIFFNESS_TEST", int(method.stiffness_test), "report the integrator's stiffness test"),
            ("LAG_HAS_SWITCHES", int(bool(method.parts)), "report the composite integrator's switches"),
            ("LAG_HAS_TOLERANCES", int("rtol" in method.options), "the integrator takes rtol and atol"),
            ("LAG_HAS_LANES", lanes["switch"] if lanes else 0,
             "the sweep runs its members in SIMD lanes (lag_run_lanes)")]


def _linear_algebra(kernel: Kernel) -> str:
    """Only the factorisations the scene calls: unused static functions are warnings."""
    dense = layout_kind(kernel) == "dense"
    needs_lu = kernel.solver == "lu" or bool(kernel.constraints)
    schur = layout_kind(kernel) == "tree" and bool(kernel.constraints)   # the tree's lag_solve factors A M^-1 A^T
    needs_cholesky = kernel.solver == "cholesky" and (dense or schur)
    files = (("cholesky.c", needs_cholesky), ("lu.c", needs_lu), ("lu_condition.c", kernel.solver == "lu"))
    return "".join(c_file(name) + "\n" for name, needed in files if needed)


def _gram_tables(kernel: Kernel) -> dict:
    """The pattern of the constraints' Jacobian A, for the projection's G = A Aᵀ (lag_gram, driver.c):
    the columns where each row may be nonzero (row i's are a_columns[a_start[i] .. a_start[i + 1])),
    and the pairs of rows (i >= j, by i) that share a column, the entries of G that are not zero."""
    if kernel.constraint_rows is None:
        return {}
    columns = [[] for _ in kernel.constraints]
    for store in kernel.constraint_rows.stores:
        if store.array == "A" and store.value != 0:
            columns[store.index[0]].append(store.index[1])
    columns = [sorted(row) for row in columns]
    starts = [0]
    for row in columns:
        starts.append(starts[-1] + len(row))
    pairs = [f"{{ {i}, {j} }}" for i in range(len(columns)) for j in range(i + 1) if set(columns[i]) & set(columns[j])]
    return {"a_start": starts, "a_columns": [k for row in columns for k in row], "gram_pair_count": len(pairs),
            "gram_pair_lines": [", ".join(pairs[at:at + 8]) for at in range(0, len(pairs), 8)]}


def stem(kernel: Kernel) -> str:
    return f"{kernel.model_name}_{kernel.scene_name}"


def _option_fields(allowed: tuple[str, ...]) -> list[dict[str, str]]:
    """The options the standalone program accepts (each sets the lag_options field of its name),
    with their checks; an option of words takes its index there (--norm=1), and is printed as its word."""
    return [{"key": key, "flag": OPTIONS[key].flag, "field": key, "check": OPTIONS[key].c_accepts,
             "requirement": OPTIONS[key].number_requirement, "cast": OPTIONS[key].c_cast,
             "words": [c_string(word) for word in OPTIONS[key].choices]}
            for key in OPTION_ORDER if key in allowed]


def _options_initializer(options: dict[str, float], atol_each: str = "NULL") -> str:
    """lag_options in field order: rtol, atol, step, max_step, stages, norm, max_steps (0: the default),
    atol_each (the name of the array of the atol of each component of y, or NULL)."""
    values = [options.get("rtol", 0.0), options.get("atol", 0.0), options.get("step", 0.0),
              options.get("max_step", 0.0)]
    counts = [str(int(options.get("stages", 0))), str(int(options.get("norm", 0))),
              f"{int(options.get('max_steps', 0))}L"]
    return ", ".join([_literal(v) for v in values] + counts + [atol_each])


def _atol_tables(kernel: Kernel) -> dict:
    """The standalone program's tables of the atol per component (templates/c/model.c.j2): the
    names (tolerances.component_names), the lag_input_units slot of each (parameters, starts,
    velocities), each coordinate's family, the scene's values in SI (-1: not given)."""
    coordinates, n = tuple(kernel.coordinates), kernel.n
    names = component_names(coordinates)
    slots = {f"{q}.{part}": len(kernel.parameters) + offset + i
             for offset, part in ((0, "start"), (n, "velocity")) for i, q in enumerate(coordinates)}
    given = dict(kernel.integrator.atol_each)
    family = [names.index(q.partition("[")[0]) if "[" in q else -1 for q in coordinates]
    return {"names": names, "inputs": [slots[component_input(name, coordinates)] for name in names],
            "family": family, "positive": int(registry.get(kernel.integrator.name).implicit),
            "given": [repr(float(given[name])) if name in given else "-1.0" for name in names]}


def _input_unit_rows(kernel: Kernel) -> list[str]:
    """The initializers of lag_input_units (standalone_input.c): for each parameter, each coordinate's
    start and each one's velocity, its declared unit, its SI unit, its dimension in words and its
    factor to SI as a double and the remainder (the exact factor is their sum to about 2^-106)."""
    declared = kernel.input_units or (None,) * (len(kernel.parameters) + 2 * kernel.n)
    rows = []
    for unit in declared:
        if unit is None:
            rows.append('{ "", "", "", 1.0, 0.0 }')
            continue
        factor = Fraction(units.si_factor(unit))
        scale = float(factor)
        dimension = units.dimension(unit)
        words = "dimensionless" if dimension.dimensionless else dimension.words()
        rows.append(f"{{ {c_string(unit.text)}, {c_string(units.si_text(unit))}, {c_string(words)}, "
                    f"{scale!r}, {float(factor - Fraction(scale))!r} }}")
    return rows


def _literal(value: float) -> str:
    return f"LAG_LIT({float(value)!r})"     # 20 -> 20.0: the Q and L suffixes need a floating constant


def _print_block(block: Block, signature: tuple[str, ...], kernel: Kernel, printer: CPrinter) -> dict:
    """A block as printed lines; `unused` lists the function parameters it does not read."""
    stores = [(f"{s.array}[{_position(s, kernel)}]", printer.doprint(s.value))
              for s in block.stores if not (s.array in CLEARED and s.value == 0)]
    assignments = [(name, printer.doprint(value)) for name, value in block.assignments]
    loops = [_print_loop(loop, kernel, printer) for loop in block.loops]
    read = ({source.partition("[")[0] for _, source in block.inputs} | {s.array for s in block.stores}
            | {array for loop in block.loops for _, array, _, _ in loop.inputs}
            | {array for loop in block.loops for array, index, _ in loop.stores if index} | set(block.cleared))
    values = [*(value for _, value in block.assignments), *(s.value for s in block.stores),
              *(value for loop in block.loops for _, value in loop.assignments),
              *(value for loop in block.loops for _, _, value in loop.stores)]
    if any("t" in {x.name for x in value.free_symbols} for value in values):
        read.add("t")
    parameters = [p for p in signature
                  if (p != "lam" or kernel.constraints) and (p != "inv" or kernel.invariant_names)]
    unused = [p for p in parameters if p not in read]
    cleared = sorted({s.array for s in block.stores if s.array in CLEARED} | set(block.cleared))
    sums = block.path_sums
    after = sums.after if sums else len(loops)
    late = {name for name, source in block.inputs if sums and source.startswith(sums.array + "[")}
    return {"inputs": [(name, source) for name, source in block.inputs if name not in late],
            "read_after_sums": [(name, source) for name, source in block.inputs if name in late],
            "assignments": assignments, "stores": stores, "unused": unused,
            "cleared": [f"memset({array}, 0, {ARRAY_SIZES[array]});" for array in cleared],
            "accumulators": block.accumulators, "loops": loops[:after], "path_sums": block.path_sums,
            "swept": loops[after:]}


# Arrays set to zero before a block fills them, so that their structurally zero entries need
# no statement: the mostly empty Dq and Dv of a large model (a derivative of each residual by
# each state entry) would otherwise be one store per entry. A block may ask for more
# (Block.cleared): the loops of the local form add into K and b.
CLEARED = JACOBIAN_ARRAYS
ARRAY_SIZES = {"y0": "sizeof(real) * LAG_NY", "K": "sizeof(real) * LAG_NM", "b": "sizeof(real) * LAG_NK",
               **{array: "sizeof(real) * LAG_JAC_SIZE" for array in CLEARED}}


def _print_loop(loop: Loop, kernel: Kernel, printer: CPrinter) -> dict:
    """A Loop as C: `count` > 1 is a for loop over i, a single member a block with i = 0."""
    def element(array: str, index) -> str:
        if not index:
            return array                                            # an accumulator
        offset, stride = index[0] if len(index) == 1 else \
            _jacobian_position(index, kernel) if array in CLEARED else _band_position(index, kernel)
        return f"{array}[{_affine(offset, stride if loop.count > 1 else 0)}]"
    return {"count": loop.count,
            "inputs": [(name, element(array, ((offset, stride),))) for name, array, offset, stride in loop.inputs],
            "assignments": [(name, printer.doprint(value)) for name, value in loop.assignments],
            "stores": [(element(array, index), printer.doprint(value)) for array, index, value in loop.stores]}


def _band_position(index, kernel: Kernel) -> tuple[int, int]:
    """(offset, stride) of entry (row, column) of M over the members: K[row] when M is diagonal,
    K[row (w + 1) + row - column] in the band of half-width w; of field `column` of link `row`'s
    record in the tree layout."""
    (row, stride), (column, _) = index
    if kernel.layout.kind == "diagonal":
        return row, stride
    if kernel.layout.kind == "tree":
        return row * kernel.layout.record + column, stride * kernel.layout.record
    width = kernel.layout.bandwidth + 1
    return row * width + row - column, stride * width


def _jacobian_position(index, kernel: Kernel) -> tuple[int, int]:
    """(offset, stride) of entry (row, column) of Dq, Dv or Dz over the members: the slots of
    both layouts are affine in (row, column)."""
    (row, stride), (column, _) = index
    slot = kernel.jacobian_layout.slot
    return slot(row, column), slot(row + stride, column + stride) - slot(row, column)


def _affine(offset: int, stride: int) -> str:
    """offset + stride·i as C or Python: "i", "2 * i + 1", "7"."""
    if stride == 0:
        return str(offset)
    term = "i" if stride == 1 else f"{stride} * i"
    return term if offset == 0 else f"{term} + {offset}" if offset > 0 else f"{term} - {-offset}"


def _position(store: Store, kernel: Kernel) -> int:
    """The flat index of a store: row-major matrices, or M where kernel.layout puts it."""
    if len(store.index) == 1:
        return store.index[0]
    row, column = store.index
    if store.array in ("K", "M") and kernel.layout is not None:
        return kernel.layout.coordinate_slot(row, column)
    if store.array in CLEARED:
        return kernel.jacobian_layout.slot(row, column)
    columns = {"K": kernel.size, "A": kernel.n, "M": kernel.n, "Dp": len(kernel.parameters)}[store.array]
    return row * columns + column
