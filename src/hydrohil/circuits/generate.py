"""C of a circuit (SPEC §12.6): node and state indices as constants, the components' laws (core/components.h)
called in a fixed order, node sums in a fixed order, the modes' updates after each step, the outputs; one
file the compiler sees whole (no table walk, no function pointer per component). The fixed-step loop runs
the core's Butcher tableaus (core/rk.c, one source of them) over the circuit's states.

Interface of the generated file (``hc_*``; :mod:`hydrohil.circuits.build` compiles and loads it):
``hc_init(P, u, y, m)`` the initial state (under the inputs u of step 0), ``hc_run(P, y, m, method, h, n, every, u, log, *rows)`` n steps with
the inputs u[k*NU..] held over step k and a log row (NLOG columns) every ``every`` steps (its loop's, its logs'
arguments: build.CDEF; status 4 and ``*steps``: a state left its physical range), ``hc_step`` one step (a plant,
the FMU), ``hc_rhs(P, y, m, u, dy)`` the right-hand side (for the nodes' stiffness), ``hc_state_bounds(P, lo,
hi)`` and ``hc_unphysical(P, y)`` the states' physical ranges (library.Emit.bounds) and the first state outside
its range, ``hc_sensed(x, sensor, rng, k)`` / ``hc_sensed_rows`` what a loop's sensor reads.
"""

from __future__ import annotations

import copy
import math
import re

from hydrohil.circuits.circuit import Circuit

PRESSURE_FLOOR = -0.99e5      # Pa gauge: node pressures are floored here, as the chambers' (HH_P_MIN)


class Layout:
    """Where each value of a circuit lives in the generated C: parameters P[], inputs u[], states y[], modes
    m[], log columns."""

    def __init__(self, c: Circuit):
        self.circuit = c
        self.params = _params(c)
        self.slot = {k: i for i, (k, _) in enumerate(self.params)}
        self.inputs = list(c.inputs)
        self.states = [f"{n}.p" for n in c.state_nodes] + [f"{comp.name}.{s}" for comp in c.components.values()
                                                             for s, _ in comp.states]
        self.state_units = ["Pa"] * len(c.state_nodes) + [u for comp in c.components.values()
                                                          for _, u in comp.states]
        self.modes = [f"{comp.name}.mode" for comp in c.components.values() if comp.modes]
        self.mode_names = {f"{comp.name}.mode": comp.modes for comp in c.components.values() if comp.modes}
        self.outputs: list[tuple[str, str]] = []      # (log column, SI unit)

    def values(self):
        import numpy as np
        return np.array([v for _, v in self.params], dtype=np.float64)

    def of(self, c: Circuit) -> "Layout":
        """This layout (of a circuit of ``c``'s :func:`structure`) for ``c``: its values, the rest shared."""
        lay = copy.copy(self)
        lay.circuit, lay.params = c, _params(c)
        return lay


def _params(c: Circuit) -> list[tuple[str, float]]:
    """The circuit's values in P[]'s order: the fluid's, each component's (its parameters and derived values,
    then its tables' points), each node's own volume."""
    params: list[tuple[str, float]] = [(f"fluid.{k}", v) for k, v in c.fluid.items()]
    for comp in c.components.values():
        for k, v in comp.values.items():
            params.append((f"{comp.name}.{k}", math.nan if v is None else float(v)))
        for name, (xs, fs) in comp.tables.items():       # a table's points: its x's, then its values
            params += [(f"{comp.name}.{name}.x[{i}]", float(x)) for i, x in enumerate(xs)]
            params += [(f"{comp.name}.{name}.f[{i}]", float(f)) for i, f in enumerate(fs)]
    for node in c.nodes:
        params.append((f"node.{node}.volume", c.node_volumes.get(node, 0.0)))   # its own; + components
    return params


def structure(c: Circuit) -> tuple:
    """What of circuit ``c`` its generated C depends on: everything :func:`generate` reads but the parameters'
    values, which are P[], not code. Two circuits of one structure have one C text (tests: every example
    circuit's values changed at random, signs and zeros too, give its text), so :func:`generated` makes it once.
    The values it does read: which are not given (NaN: a constant bulk modulus or eq 21, a driven fixed
    pressure), the [initial] pressures (written as numbers) and the lowest fixed pressure's node (the others'
    first guess)."""
    def missing(v):
        return v is None or v != v
    fixed = [(c.components[comp].values[key], n) for n, (comp, key) in c.fixed.items()
             if not missing(c.components[comp].values[key])]
    return (tuple(c.fluid), tuple(c.nodes), tuple(c.fixed.items()), tuple(c.inputs), tuple(c.initial.items()),
            min(fixed)[1] if fixed else None,
            tuple((comp.name, comp.type.name, tuple(comp.ports.items()), comp.coupled, tuple(comp.actuators),
                   tuple(comp.values), tuple(k for k, v in comp.values.items() if missing(v)),
                   tuple((name, len(xs)) for name, (xs, _) in comp.tables.items()))
                  for comp in c.components.values()))


_GENERATED: dict[tuple, tuple[str, Layout]] = {}      # structure -> (C text, its layout), this process's


def generated(c: Circuit) -> tuple[str, Layout]:
    """:func:`generate`'s (C text, layout) of ``c``, the text made once per structure in a process (a study's
    runs, a paper scenario converted run after run: one structure, many values)."""
    key = structure(c)
    entry = _GENERATED.get(key)
    if entry is None:
        source, lay = generate(c)
        template = copy.copy(lay)
        template.circuit, template.params = None, []     # (no circuit kept alive by the cache)
        if len(_GENERATED) >= 64:
            _GENERATED.clear()
        entry = _GENERATED[key] = (source, template)
    return entry[0], entry[1].of(c)


class _View:
    """One instance as its type's emit() sees it."""

    def __init__(self, lay: Layout, comp):
        self.lay, self.comp = lay, comp
        self.mode = f"m[{lay.modes.index(comp.name + '.mode')}]" if comp.modes else "0"
        self.moving = comp.coupled or comp.name        # whose states are its motion (a coupled rod: its load's)

    def par(self, key: str) -> str:
        sig = f"{self.comp.name}.{key}"
        if sig in self.lay.inputs:
            return f"u[{self.lay.inputs.index(sig)}]"
        return f"P[{self.lay.slot[sig]}]"

    def nominal(self, key: str) -> str:
        """A parameter's value as the file gives it (P), also where a signal or a fault drives it (a physical
        range's bound: of the parameters alone, hc_state_bounds)."""
        return f"P[{self.lay.slot[f'{self.comp.name}.{key}']}]"

    def p(self, port: str) -> str:
        return _pressure(self.lay, self.comp.ports[port])

    def x(self, state: str) -> str:
        return f"y[{self.lay.states.index(self.moving + '.' + state)}]"

    def dx(self, state: str) -> str:
        """its state's derivative in the right-hand side (computed before the nodes' rates)"""
        return f"dy[{self.lay.states.index(self.moving + '.' + state)}]"

    def table(self, name: str) -> str | None:
        """A table's C arguments (its x's, its values, its length) in P, or None when the file gives none."""
        if name not in self.comp.tables:
            return None
        n = len(self.comp.tables[name][0])
        slot = self.lay.slot
        return f"&P[{slot[f'{self.comp.name}.{name}.x[0]']}], &P[{slot[f'{self.comp.name}.{name}.f[0]']}], {n}"

    def coupled_views(self) -> list:
        """The views of the actuators coupled to this load (their rod_end or shaft), in netlist order."""
        return [_View(self.lay, self.lay.circuit.components[a]) for a in self.comp.actuators]

    def v(self, name: str) -> str:
        return f"v_{_ident(self.comp.name)}_{name}"

    def fluid(self, key: str) -> str:
        return f"P[{self.lay.slot['fluid.' + key]}]"


def _state_index(expr: str) -> int:
    """k when the C expression is the state y[k] itself, else -1."""
    match = re.fullmatch(r"y\[(\d+)\]", expr.strip())
    return int(match.group(1)) if match else -1


def _pressure(lay: Layout, node: str) -> str:
    c = lay.circuit
    if node in c.fixed:
        comp, key = c.fixed[node]
        sig = f"{comp}.{key}"
        return f"u[{lay.inputs.index(sig)}]" if sig in lay.inputs else f"P[{lay.slot[sig]}]"
    return f"y[{c.state_nodes.index(node)}]"


def generate(c: Circuit) -> tuple[str, Layout]:
    """The C source of circuit ``c`` and its layout."""
    lay = Layout(c)
    emits = [(comp, comp.type.emit(_View(lay, comp))) for comp in c.components.values()]
    ny, nm, nu = len(lay.states), len(lay.modes), len(lay.inputs)
    nodes, pairs = _node_terms(c, lay, emits), _coupled_pairs(c, emits)
    rhs = _rhs_lines(c, lay, emits, nodes, reference=False)
    ref_rhs = _rhs_lines(c, lay, emits, nodes, reference=True)
    start_rhs = _rhs_lines(c, lay, emits, nodes, reference=False, start=pairs)
    lay.coupled = sorted({(c.state_nodes[i], c.state_nodes[j]) for i, j, _, _ in pairs})
    updates = [f"    {_mode_update(comp, e, lay)}   /* {comp.name} */" for comp, e in emits
               if (e.mode_update or e.mode_of_state) and not e.guards]
    guarded = [f"    {_mode_update(comp, e, lay)}   /* {comp.name} */" for comp, e in emits
               if (e.mode_update or e.mode_of_state) and e.guards]
    guards = [(f"{comp.name}.{name}", value, reset) for comp, e in emits for name, value, reset in e.guards]
    lay.guards = [name for name, _, _ in guards]
    guard_cases = [f"    gv[{g}] = {value};   /* {name} */" for g, (name, value, _) in enumerate(guards)]
    resets = [f"    case {g}: {reset} break;   /* {name} */" for g, (name, _, reset) in enumerate(guards)]
    ref_modes = [f"    m[{lay.modes.index(comp.name + '.mode')}] = {e.mode_of_state};   /* {comp.name} */"
                 for comp, e in emits if e.mode_of_state]
    delays = [(lay.inputs.index(f"{comp.name}.{key}"), _View(lay, comp).par(par), comp, key, par)
              for comp, e in emits for key, par in e.delays
              if f"{comp.name}.{key}" in lay.inputs]                   # (a constant needs no delay)
    lay.delayed = [f"{comp.name}.{key}" for _, _, comp, key, _ in delays]
    lay.delay_params = {f"{comp.name}.{key}": f"{comp.name}.{par}" for _, _, comp, key, par in delays}
    out_exprs, ref_exprs = [], []                  # (each output's C expression, in the log's order; the reference's)
    for comp, e in emits:
        for st, unit in comp.states:               # every state of a component is logged
            e.outputs.setdefault(st, (f"y[{lay.states.index(f'{comp.name}.{st}')}]", unit))
        for name, (expr, unit) in e.outputs.items():
            lay.outputs.append((f"{comp.name}.{name}", unit))
            out_exprs.append(expr)
            ref_exprs.append(e.reference_outputs.get(name, expr))
    outs = [f"    o[{i}] = {expr};" for i, expr in enumerate(out_exprs)]
    ref_outs = [f"    o[{i}] = {expr};" for i, expr in enumerate(ref_exprs) if expr != out_exprs[i]]
    delay_cases = [f"    case {d}: return {expr};   /* {comp.name}.{key} */" for d, (_, expr, comp, key, _) in
                   enumerate(delays)]
    if delays:
        step_inputs = ["    double u[NU];", "    if (delayed_inputs(P, h, y, u_in, u))   /* (h not the lines' step) */",
                       "        return 2;"]
    else:
        step_inputs = ["    const double *u = u_in;"]
    step_inputs += [f"    {_mode_update(comp, e, lay)}   /* {comp.name}: its clamp of a driven parameter, from now */"
                    for comp, e in emits if any(f"{comp.name}.{k}" in lay.inputs for k in e.clamps)]

    bounds = [(i, "-NODE_BOUND", "NODE_BOUND", f"{node}.p") for i, node in enumerate(c.state_nodes)]
    bounds += [(lay.states.index(f"{comp.name}.{st}"), lo or "-INFINITY", hi or "INFINITY", f"{comp.name}.{st}")
               for comp, e in emits for st, (lo, hi) in e.bounds.items()]
    if any("u[" in lo + hi for _, lo, hi, _ in bounds):     # (a library mistake: the check has no inputs)
        raise RuntimeError(f"circuit {c.name}: a physical range reads an input (Emit.bounds: _View.nominal)")
    bound_checks = [f"    if (!({_in_range(f'y[{i}]', lo, hi)}))   /* {name} */\n        return {i + 1};"
                    for i, lo, hi, name in bounds]
    bound_sets = [f"    lo[{i}] = {lo};   /* {name} */\n    hi[{i}] = {hi};" for i, lo, hi, name in bounds]
    nout = len(outs)
    cols = ["t"] + [f"{n}.p" for n in c.nodes] + [n for n, _ in lay.outputs] + lay.modes
    clash = sorted((set(cols) & set(c.inputs)) | {n for n in cols if cols.count(n) > 1})
    if clash:               # (a log column and an input, or two columns, of one name: a library mistake)
        raise RuntimeError(f"circuit {c.name}: the signal name {clash[0]!r} is given twice (outputs, modes, "
                           "inputs and node pressures name the log's columns: one name each)")
    lay.log_columns = cols
    init = [f"    y[{i}] = {_initial(c, lay, node)};   /* {node} */" for i, node in enumerate(c.state_nodes)]
    init += [f"    y[{lay.states.index(f'{comp.name}.{st}')}] = {expr};   /* {comp.name}.{st} */"
             for comp, e in emits for st, expr in e.initial.items()]
    node_cols = [f"    row[LOG_NODES + {i}] = {_pressure(lay, n)};   /* {n} */" for i, n in enumerate(c.nodes)]
    value_cases = [f"    case LOG_NODES + {i}: return {_pressure(lay, n)};   /* {n} */" for i, n in enumerate(c.nodes)]
    value_cases += [f"    case LOG_OUTPUTS + {i}: return {expr};   /* {lay.outputs[i][0]} */"
                    for i, expr in enumerate(out_exprs)]
    value_cases += [f"    case LOG_MODES + {i}: return (double)m[{i}];   /* {name} */" for i, name in enumerate(lay.modes)]
    state_of = [-1] + [_state_index(_pressure(lay, n)) for n in c.nodes] + [_state_index(e) for e in out_exprs] \
        + [-1] * len(lay.modes)             # (hc_run copies a column that is a state, log_value computes the rest)
    held = [f"    m[{lay.modes.index(comp.name + '.mode')}] = {e.mode_at_rest};   /* {comp.name} */"
            for comp, e in emits if e.mode_at_rest]
    held += [f"    y[{lay.states.index(f'{comp.name}.{st}')}] = {expr};   /* {comp.name}.{st} */"
             for comp, e in emits for st, expr in e.at_rest.items()]
    text = f"""/* GENERATED by hydrohil.circuits.generate: do not edit. A circuit's structure, not named (its parameters
 * are values P[], not code: every circuit of this structure shares this file and its compiled module). */
#include "core.h"
#include "components.h"
#include "hc_core.h"
#include "rk.c"
#include "control.c"
#include "watchdog.c"
#include "sensors.c"
#include "rng.c"
#include "link.c"
#include "delay.c"

enum {{ NY = {max(ny, 1)}, NM = {max(nm, 1)}, NU = {max(nu, 1)}, NOUT = {max(nout, 1)}, NLOG = {len(cols)},
       NNODES = {len(c.state_nodes)}, NG = {len(guards)} }};   /* y: the NNODES node pressures, then the components' states; NG guards */
/* log columns: t, the nodes' pressures, the components' outputs, the modes */
enum {{ LOG_T, LOG_NODES, LOG_OUTPUTS = LOG_NODES + {len(c.nodes)}, LOG_MODES = LOG_OUTPUTS + {nout} }};

/* per log column, the state it is (y[LOG_STATE[j]]), or -1: computed (log_value) */
static const int LOG_STATE[NLOG] = {{ {", ".join(map(str, state_of))} }};

/* sc: per state node (c, (1 - c)/g, its Gershgorin reach) of hc_node.h's stiff-node form, NOT_STIFF: c = 1 */
enum {{ NSC = 3 * NNODES + 3 }};
static const double NOT_STIFF[NSC] = {{ {", ".join(["1.0, 0.0, 0.0"] * (len(c.state_nodes) + 1))} }};

/* (HH_RESTRICT: the state, modes, inputs, parameters and derivatives are distinct arrays at every call, so that
 * the parameters read stay in registers across the derivatives' stores) */
HH_INLINE void rhs(const double *HH_RESTRICT y, const int64_t *HH_RESTRICT m, const double *HH_RESTRICT u,
                   const double *HH_RESTRICT P, const double *HH_RESTRICT sc, double *HH_RESTRICT dy)
{{
    (void)m; (void)u; (void)P; (void)y; (void)sc;
{chr(10).join(rhs)}
}}

/* rhs at a step's start y, the step's stiff-node constants sc (hc_node.h: each node's conductance and
 * capacitance here, for a step of h) computed on the way, from the same flows. (HH_INLINE, as the step's other
 * parts: project, first_crossing, delayed_inputs: the step is one function, as the core's, 9 % fewer
 * instructions than with them called; benchmarks/paper_circuit_c.py) */
HH_INLINE void rhs_start(const double *HH_RESTRICT y, const int64_t *HH_RESTRICT m, const double *HH_RESTRICT u,
                         const double *HH_RESTRICT P, double h, double *HH_RESTRICT sc, double *HH_RESTRICT dy)
{{
    (void)m; (void)u; (void)P; (void)y; (void)h;
    sc[NSC - 3] = 1.0;
    sc[NSC - 2] = 0.0;
    sc[NSC - 1] = 0.0;
{chr(10).join(start_rhs)}
}}

/* The continuous reference (SPEC §6, §12.4): the same laws, the modes that are functions of the state evaluated
 * at each call, end stops and spool ends as stiff spring-dampers (no clamp) */
static void reference_rhs(const double *y, const int64_t *m, const double *u, const double *P, double *dy)
{{
    (void)m; (void)u; (void)P; (void)y;
{chr(10).join(ref_rhs)}
}}

static void reference_modes(const double *y, int64_t *m, const double *u, const double *P)
{{
    int i;
    (void)u; (void)P; (void)y;
    for (i = 0; i < NM; i++)
        m[i] = 0;
{chr(10).join(ref_modes)}
}}

/* After every (sub)step: the modes of the components without events (functions of the state, clamps) */
HH_INLINE void project(double *y, int64_t *m, const double *u, const double *P)
{{
    (void)m; (void)u; (void)P; (void)y;
{chr(10).join(updates)}
}}

/* The guards of the components with events (library: Emit.guards), all at once (what they share computed once):
 * >= 0 while the mode holds, +inf where a guard does not apply */
HH_INLINE void guard_values(const double *y, const int64_t *m, const double *u, const double *P, double *gv)
{{
    (void)m; (void)u; (void)P; (void)y; (void)gv;
{chr(10).join(guard_cases)}
}}

/* The transition of guard g (its component's reset) */
static void transition(int g, double *y, int64_t *m, const double *u, const double *P)
{{
    (void)m; (void)u; (void)P; (void)y;
    switch (g) {{
{chr(10).join(resets)}
    default: break;
    }}
}}

/* The components with events switched by their own statecharts (their modes at the start and in the rest
 * march; a step locates their guards instead) */
static void guarded_updates(double *y, int64_t *m, const double *u, const double *P)
{{
    (void)m; (void)u; (void)P; (void)y;
{chr(10).join(guarded)}
}}

static void update_modes(double *y, int64_t *m, const double *u, const double *P)
{{
    project(y, m, u, P);
    guarded_updates(y, m, u, P);
}}

/* The guard crossed first between y0 and y1 (a step in the modes m) and the fraction theta of the step at which
 * it crosses (linear between its two values, hybrid.c's rule; ties: the first guard), or -1 */
HH_INLINE int first_crossing(const double *y0, const double *y1, const int64_t *m, const double *u, const double *P,
                             double *theta)
{{
    double g0[NG + 1], g1[NG + 1];
    int best = -1, crossed = 0, g;
    *theta = 1.0;
    guard_values(y1, m, u, P, g1);
    for (g = 0; g < NG; g++)
        crossed |= g1[g] < 0.0;
    if (!crossed)
        return -1;
    guard_values(y0, m, u, P, g0);     /* (at the start: only when a guard crossed) */
    for (g = 0; g < NG; g++) {{
        if (g1[g] < 0.0) {{
            double th = g0[g] <= 0.0 ? 0.0 : g0[g] / (g0[g] - g1[g]);
            if (best < 0 || th < *theta) {{
                best = g;
                *theta = th;
            }}
        }}
    }}
    return best;
}}

static void outputs(const double *y, const int64_t *m, const double *u, const double *P, double *o)
{{
    (void)m; (void)u; (void)P; (void)y; (void)o;
{chr(10).join(outs)}
}}

/* Each state's physical range (a node's pressure within NODE_BOUND; a component's states: its declaration,
 * library.py Emit.bounds; none: +-INFINITY), far outside what any rig reaches: beyond it the run has diverged
 * (the paper's rig: the core's hh_diverged, loop.c) */
#define NODE_BOUND 1e9
void hc_state_bounds(const double *P, double *lo, double *hi)
{{
    int i;
    (void)P;
    for (i = 0; i < NY; i++) {{
        lo[i] = -INFINITY;
        hi[i] = INFINITY;
    }}
{chr(10).join(bound_sets)}
}}

/* The first state (its index + 1) outside its physical range or not finite there; 0: none */
HH_INLINE int64_t unphysical(const double *P, const double *y)
{{
    (void)P; (void)y;
{chr(10).join(bound_checks)}
    return 0;
}}

int64_t hc_unphysical(const double *P, const double *y)
{{
    return unphysical(P, y);
}}

/* the stiff-node constants sc (NSC) of a step of h from (y, m) under u (hc_node.h; circuit show's report) */
void hc_stiff_constants(const double *P, const double *y, const int64_t *m, const double *u, double h, double *sc)
{{
    double dy[NY];
    rhs_start(y, m, u, P, h, sc, dy);
}}

/* the stiff-node form's lambda*h and its coupled modes' bound (hc_node.h) */
double hc_lambda_h_max(void)
{{
    return HC_LAMBDA_H_MAX;
}}

double hc_lambda_h_row(void)
{{
    return HC_LAMBDA_H_ROW;
}}

/* dy/dt at (y, m) under inputs u without the stiff-node form (the stiffness estimate of hydrohil.circuits.run,
 * the rest's flow balance, linear analysis) */
void hc_rhs(const double *P, const double *y, const int64_t *m, const double *u, double *dy)
{{
    rhs(y, m, u, P, NOT_STIFF, dy);
}}

/* ---- delayed inputs (library: Emit.delays; the paper's valve's input delay, SPEC §3.1): the core's delay
 * line (delay.c: the spool input over a step is the step average of the two held commands it straddles),
 * its memory in y after the NY states: [the step h it is sized for] then per line [n, alpha, pos, n + 2 held
 * commands] (hc_state_size), set by hc_init */
enum {{ ND = {len(delays)}, MEM = NY + (ND > 0 ? 1 : 0) }};
static const int DELAYED[{max(len(delays), 1)}] = {{ {", ".join(str(j) for j, *_ in delays) or "0"} }};

static double delay_time(int d, const double *P)
{{
    (void)P;
    switch (d) {{
{chr(10).join(delay_cases)}
    default: return 0.0;
    }}
}}

/* the doubles a state needs for steps of h: the NY states and the delay lines' memory */
int64_t hc_state_size(const double *P, double h)
{{
    int64_t size = MEM;
    double alpha;
    int d;
    for (d = 0; d < ND; d++)
        size += 3 + hh_delay_steps(delay_time(d, P), h, &alpha) + 2;
    return size;
}}

/* delay line d's memory (in y after MEM) as delay.c's hh_delay; returns the next line's */
HH_INLINE double *delay_line(double *line, hh_delay *dl)
{{
    dl->buf = line + 3;
    dl->n = (int)line[0];
    dl->size = dl->n + 2;
    dl->alpha = line[1];
    dl->pos = (int)line[2];
    return line + dl->n + 5;
}}

/* The inputs u of a step of h as the components see them (ud): each delayed one through its line, pushed.
 * Returns 2 (nothing pushed) when h is not the step the lines were sized for. */
HH_INLINE int delayed_inputs(const double *P, double h, double *y, const double *u, double *ud)
{{
    double *line = y + MEM, *next, u_new, u_old;
    hh_delay dl;
    int i, d;
    (void)P;
    if (ND > 0 && h != y[NY])
        return 2;
    for (i = 0; i < NU; i++)
        ud[i] = u[i];
    for (d = 0; d < ND; d++, line = next) {{
        next = delay_line(line, &dl);
        ud[DELAYED[d]] = delay_push(&dl, u[DELAYED[d]], &u_new, &u_old);
        line[2] = (double)dl.pos;
    }}
    return 0;
}}

/* The delayed inputs of a step under u as delayed_inputs gives them, the lines left as they were (a log row's
 * <input>.seen: the row's step, the last row's as its line would give it; delay.c's delay_peek) */
static void delayed_peek(double *y, const double *u, double *seen)
{{
    double *line = y + MEM;
    hh_delay dl;
    int d;
    for (d = 0; d < ND; d++) {{
        line = delay_line(line, &dl);
        seen[d] = delay_peek(&dl, u[DELAYED[d]]);
    }}
}}

/* the per-step interface of delayed_inputs (a reference run's delayed inputs) */
int hc_delayed_inputs(const double *P, double h, double *y, const double *u, double *ud)
{{
    return delayed_inputs(P, h, y, u, ud);
}}

/* The initial state under the inputs u for steps of h (y: hc_state_size(P, h) doubles): the nodes' initial
 * guesses, the components' initial states and modes, each delay line full of its input's value now */
void hc_init(const double *P, const double *u, double h, double *y, int64_t *m)
{{
    double *line = y + MEM;
    hh_delay dl;
    int i, d;
    (void)u; (void)h; (void)line; (void)dl; (void)d;
    for (i = 0; i < NM; i++)
        m[i] = 0;
{chr(10).join(init)}
    if (ND > 0)
        y[NY] = h;
    for (d = 0; d < ND; d++) {{
        int n = hh_delay_steps(delay_time(d, P), h, &line[1]);
        line[0] = (double)n;
        hh_delay_init(&dl, line + 3, n, line[1], u[DELAYED[d]]);
        line[2] = (double)dl.pos;
        line += n + 5;
    }}
    update_modes(y, m, u, P);
}}

/* The components' modes and states once the nodes settled at rest (SPEC §12.5; library: Emit.mode_at_rest,
 * Emit.at_rest) */
void hc_hold(const double *P, const double *u, double *y, int64_t *m)
{{
    (void)m; (void)u; (void)P; (void)y;
{chr(10).join(held)}
}}

static void log_row(double t, const double *y, const int64_t *m, const double *u, const double *P, double *row)
{{
    double o[NOUT];
    int i;
    row[LOG_T] = t;
{chr(10).join(node_cols)}
    outputs(y, m, u, P, o);
    for (i = 0; i < {nout}; i++)
        row[LOG_OUTPUTS + i] = o[i];
    for (i = 0; i < {nm}; i++)
        row[LOG_MODES + i] = (double)m[i];
}}

/* log_row's column j alone (what a loop reads of step k: hc_run computes only those columns, not the row) */
HH_INLINE double log_value(int64_t j, double t, const double *y, const int64_t *m, const double *u, const double *P)
{{
    (void)t; (void)y; (void)m; (void)u; (void)P;
    switch (j) {{
    case LOG_T: return t;
{chr(10).join(value_cases)}
    default: return NAN;
    }}
}}

/* dy/dt of the continuous reference at y under inputs u; a node at the pressure floor does not fall further
 * (cavitation, as the core's reference) */
void hc_reference_rhs(const double *P, const double *y, const double *u, double *dy)
{{
    int64_t m[NM];
    int i;
    reference_modes(y, m, u, P);
    reference_rhs(y, m, u, P, dy);
    for (i = 0; i < NNODES; i++)
        if (y[i] <= {PRESSURE_FLOOR!r} && dy[i] < 0.0)
            dy[i] = 0.0;
}}

/* One explicit step of h of the continuous reference (maxstep's explicit runs of the continuous model) from y0
 * into yout under inputs u, with the core's tableau tab: rk.c's rk_step over NY states, its sums in its order */
HH_INLINE void continuous_step(const hh_tableau *tab, const double *P, const double *y0, const double *u, double h,
                               double *yout)
{{
    double k[HH_MAX_STAGES][NY], ytmp[NY];
    int s, j, i;
    for (s = 0; s < tab->stages; s++) {{
        for (i = 0; i < NY; i++) {{
            double acc = y0[i];
            for (j = 0; j < s; j++)
                if (tab->a[s][j] != 0.0)
                    acc += h * tab->a[s][j] * k[j][i];
            ytmp[i] = acc;
        }}
        hc_reference_rhs(P, ytmp, u, k[s]);
    }}
    for (i = 0; i < NY; i++) {{
        double acc = y0[i];
        for (s = 0; s < tab->stages; s++)
            acc += h * tab->b[s] * k[s][i];
        yout[i] = acc;
    }}
}}

/* The continuous model's step in a sampled loop whose state is in another order (the core's loop, loop.c's
 * external model: maxstep's explicit runs of a paper scenario's continuous model): hh_advance_fn's arguments,
 * its context an hc_core_ctx (state i of the loop's y is the circuit's at[i]; the input `command` takes the
 * delay line's step average (1 - alpha)*u_new + alpha*u_old, delay.c's); always 0 (the loop checks the state). */
int hc_core_continuous_advance(void *ctx, double t, double h, double alpha, double u_old, double u_new, double *y)
{{
    hc_core_ctx *c = (hc_core_ctx *)ctx;
    double y1[NY];
    int64_t i;
    (void)t;
    for (i = 0; i < c->n; i++)
        c->yc[c->at[i]] = y[i];
    c->u[c->command] = (1.0 - alpha) * u_new + alpha * u_old;
    switch (c->method) {{
    case HH_EULER: continuous_step(&HH_TABLEAUS[HH_EULER], c->P, c->yc, c->u, h, y1); break;
    case HH_HEUN: continuous_step(&HH_TABLEAUS[HH_HEUN], c->P, c->yc, c->u, h, y1); break;
    case HH_RK4: continuous_step(&HH_TABLEAUS[HH_RK4], c->P, c->yc, c->u, h, y1); break;
    default: continuous_step(&HH_TABLEAUS[HH_RK3], c->P, c->yc, c->u, h, y1); break;
    }}
    for (i = 0; i < c->n; i++)
        y[i] = y1[c->at[i]];
    return 0;
}}

/* a log row of the continuous reference at (t, y) under inputs u (its modes read off the state; the outputs
 * that differ there, Emit.reference_outputs: the flows of its own laws) */
void hc_reference_row(const double *P, const double *y, const double *u, double t, double *row)
{{
    int64_t m[NM];
    double o[NOUT];
    int i;
    reference_modes(y, m, u, P);
    log_row(t, y, m, u, P, row);
    outputs(y, m, u, P, o);
{chr(10).join(ref_outs)}
    for (i = 0; i < {nout}; i++)
        row[LOG_OUTPUTS + i] = o[i];
}}

/* The stage derivatives k of an explicit step of h from y with tableau tab; held (NULL: none): the node
 * pressures kept where they are, the components' states too (the rest march of hc_rest); sc_start (NULL:
 * none): the first stage computes the step's stiff-node constants there (sc the same array). */
HH_INLINE void stages(const hh_tableau *tab, double h, const double *y, int64_t *m, const double *u, const double *P,
                      const double *sc, double *sc_start, const int64_t *held, double k[][NY])
{{
    double ytmp[NY];
    int s, j, i;
    HH_ASSUME(tab->stages <= HH_MAX_STAGES);
    HH_UNROLL for (s = 0; s < tab->stages; s++) {{
        for (i = 0; i < NY; i++) {{
            double acc = y[i];
            HH_UNROLL for (j = 0; j < s; j++)
                if (tab->a[s][j] != 0.0)     /* (a constant: the unrolled loop keeps no work for a zero) */
                    acc += h * tab->a[s][j] * k[j][i];
            ytmp[i] = acc;
        }}
        if (s == 0 && sc_start)
            rhs_start(ytmp, m, u, P, h, sc_start, k[s]);
        else
            rhs(ytmp, m, u, P, sc, k[s]);
        if (held)
            for (i = 0; i < NY; i++)
                if (i >= NNODES || held[i])
                    k[s][i] = 0.0;
    }}
}}

/* The node pressures at rest (SPEC §12.5): the components' states held (pistons and motors still, spools where
 * their command puts them), the nodes not in `held` marched with the method until no pressure moves by more
 * than rel_tol*(1 bar + |p|) in a step; the modes follow their guards. Returns the steps taken, or -1 when not
 * settled within max_steps, -2 when non-finite. */
int64_t hc_rest(const double *P, const double *u, double *y, int64_t *m, const int64_t *held, int method, double h,
                int64_t max_steps, double rel_tol)
{{
    const hh_tableau *tab = &HH_TABLEAUS[method];
    double k[HH_MAX_STAGES][NY];
    int64_t step;
    int s, i;
    for (step = 0; step < max_steps; step++) {{
        double moved = 0.0;
        stages(tab, h, y, m, u, P, NOT_STIFF, 0, held, k);
        for (i = 0; i < NNODES; i++) {{
            double acc = y[i], d;
            for (s = 0; s < tab->stages; s++)
                acc += h * tab->b[s] * k[s][i];
            if (!isfinite(acc))
                return -2;
            acc = acc < {PRESSURE_FLOOR!r} ? {PRESSURE_FLOOR!r} : acc;
            d = fabs(acc - y[i]) / (1e5 + fabs(acc));
            moved = d > moved ? d : moved;
            y[i] = acc;
        }}
        update_modes(y, m, u, P);
        if (moved < rel_tol)
            return step + 1;
    }}
    return -1;
}}

/* What the loop's sensor reports of a signal x at step k (SPEC §10): x plus white noise of standard deviation
 * sensor[3] (one normal sample of rng[0] per reading; 0 or rng NULL: none), to the nearest multiple of its
 * quantum sensor[0] (0: ideal; the encoder's rounding, sensors.c), within its range [sensor[1], sensor[2]]; and
 * its faults (circuits/faults.py), sensor[4] of them after the head of HC_SENSOR_HEAD doubles (sensor[5]: the
 * step h; sensor[6]: 1 for an encoder), each HC_SENSOR_FAULT doubles (type, first step, step after the last, a,
 * b, memory) active on the steps k_first <= k < k_end: an offset a + drift b*(t - start) (memory: start), an
 * added noise of standard deviation a (a sample of its own stream rng[1 + i], i its row), stuck at the reading
 * of its first step (memory: that reading, NaN until then and after), a dropout reporting 0, an encoder missing
 * a fraction a of its counts (the paper's rig's encoder_count_loss: while active, a of each change of count
 * lost, the lost counts staying lost; memory b: the counts lost, then the last count, NaN until the first
 * reading). A transducer takes the offset and the noise on its signal, before its own model, stuck and dropout
 * on its reading; an encoder (the paper's rig's, rig.c) counts first (less the counts lost), the faults act in
 * their order on the reading in its unit, then counted again. sensor NULL: x itself. */
enum {{ HC_SENSOR_HEAD = 7, HC_SENSOR_FAULT = 6, HC_SENSOR_STUCK = 1, HC_SENSOR_OFFSET, HC_SENSOR_NOISE,
       HC_SENSOR_DROPOUT, HC_SENSOR_COUNT_LOSS }};

/* v under the active fault row F (type, its steps, a, b, start [s]; hc_sensed's and hc_pressures_read's) at time
 * t, the rig's rule (rig.c: sense): stuck at its first value (*memory, NaN until then), an offset a + drift
 * b*(t - start), an added noise of standard deviation a (a normal sample of `stream`; NULL: none), a dropout
 * reading 0; v itself for another (an encoder's count loss acts on its counts, hc_sensed). */
HH_INLINE double sensor_fault(double v, const double *F, double t, double *memory, hh_rng *stream)
{{
    double z;
    switch ((int)F[0]) {{
    case HC_SENSOR_STUCK:
        if (isnan(*memory))
            *memory = v;
        return *memory;
    case HC_SENSOR_OFFSET: return v + (F[3] + F[4] * hh_max(t - F[5], 0.0));
    case HC_SENSOR_NOISE:
        if (stream) {{
            hh_rng_normals(stream, 1, &z);
            return v + F[3] * z;
        }}
        return v;
    case HC_SENSOR_DROPOUT: return 0.0;
    default: return v;
    }}
}}

/* hc_sensed of a sensor without faults (sensor[4] = 0): the noise, the counts, the range (the same numbers as
 * hc_sensed's path with faults: no count lost, counts - 0.0 is counts); inline in hc_run's loop */
HH_INLINE double sensed_plain(double v, const double *sensor, hh_rng *r)
{{
    double z;
    if (sensor[3] > 0.0 && r) {{
        hh_rng_normals(&r[0], 1, &z);
        v = v + sensor[3] * z;
    }}
    if (sensor[0] > 0.0)
        v = encoder_counts(v, sensor[0]) * sensor[0];
    return v < sensor[1] ? sensor[1] : v > sensor[2] ? sensor[2] : v;
}}

double hc_sensed(double x, double *sensor, void *rng, int64_t k)
{{
    hh_rng *r = (hh_rng *)rng;
    double v = x, z, t, *stuck = 0;
    int f, nf, dropout = 0, encoder, any = 0;
    if (!sensor)
        return x;
    nf = (int)sensor[4];
    if (nf == 0)                            /* no fault */
        return sensed_plain(v, sensor, r);
    encoder = sensor[6] != 0.0;
    t = (double)k * sensor[5];
    for (f = 0; f < nf; f++) {{
        double *F = sensor + HC_SENSOR_HEAD + HC_SENSOR_FAULT * f;
        if ((double)k < F[1] || (double)k >= F[2]) {{
            if ((int)F[0] == HC_SENSOR_STUCK)
                F[5] = NAN;                 /* (a window that ends lets go) */
            continue;
        }}
        if ((int)F[0] != HC_SENSOR_COUNT_LOSS)
            any = 1;
        if (encoder)
            continue;                       /* (an encoder's faults act on its reading, below) */
        switch ((int)F[0]) {{
        case HC_SENSOR_STUCK: stuck = F; break;
        case HC_SENSOR_DROPOUT: dropout = 1; break;
        default: v = sensor_fault(v, F, t, &F[5], r ? &r[1 + f] : 0); break;
        }}
    }}
    if (sensor[3] > 0.0 && r) {{
        hh_rng_normals(&r[0], 1, &z);
        v = v + sensor[3] * z;
    }}
    if (sensor[0] > 0.0) {{
        double counts = encoder_counts(v, sensor[0]), lost = 0.0;
        for (f = 0; f < nf; f++) {{             /* counts lost: every reading remembered, lost while active */
            double *F = sensor + HC_SENSOR_HEAD + HC_SENSOR_FAULT * f;
            if ((int)F[0] != HC_SENSOR_COUNT_LOSS)
                continue;
            if ((double)k >= F[1] && (double)k < F[2] && !isnan(F[5]))
                F[4] += copysign(F[3] * fabs(counts - F[5]), counts - F[5]);
            F[5] = counts;
            lost += F[4];
        }}
        v = (counts - nearbyint(lost)) * sensor[0];
    }}
    if (encoder && any) {{                     /* the reading's faults in their order, counted again */
        for (f = 0; f < nf; f++) {{
            double *F = sensor + HC_SENSOR_HEAD + HC_SENSOR_FAULT * f;
            if ((double)k >= F[1] && (double)k < F[2])
                v = sensor_fault(v, F, t, &F[5], r ? &r[1 + f] : 0);
        }}
        v = encoder_counts(v, sensor[0]) * sensor[0];
    }}
    v = v < sensor[1] ? sensor[1] : v > sensor[2] ? sensor[2] : v;
    if (stuck) {{
        if (isnan(stuck[5]))
            stuck[5] = v;
        v = stuck[5];
    }}
    return dropout ? 0.0 : v;
}}

/* What the sensor read of a signal logged every `every` steps (rows x): one reading per step in order, a row's
 * of its value, the readings of the steps between rows (their noise draws, a fault's first reading) of the
 * row's value too and not kept (exact when every row is logged). */
void hc_sensed_rows(const double *x, int64_t rows, int64_t every, double *sensor, void *rng, double *out)
{{
    int64_t i, j;
    for (i = 0; i < rows; i++) {{
        out[i] = hc_sensed(x[i], sensor, rng, i * every);
        if (i + 1 < rows)
            for (j = 1; j < every; j++)
                hc_sensed(x[i], sensor, rng, i * every + j);
    }}
}}

/* One explicit (sub)step of h from y (modes m) into y1 (node pressures floored, the components' states without
 * subnormal magnitudes (core.h: hh_unsubnormal, as the core's hybrid_step_tab), then projected: the modes that
 * follow the state into m1, m kept for a substep not taken). Returns 1 when the state went non-finite. */
HH_INLINE int substep(const hh_tableau *tab, double h, const double *y, int64_t *m, const double *u, const double *P,
                      double *sc, int first, double *y1, int64_t *m1)
{{
    double k[HH_MAX_STAGES][NY];
    int s, i;
    stages(tab, h, y, m, u, P, sc, first ? sc : 0, 0, k);
    double bad = 0.0;   /* acc - acc: 0 when finite, NaN otherwise (one test after the loop) */
    for (i = 0; i < NY; i++) {{
        double acc = y[i];
        HH_UNROLL for (s = 0; s < tab->stages; s++)
            acc += h * tab->b[s] * k[s][i];
        y1[i] = i < NNODES ? (acc < {PRESSURE_FLOOR!r} ? {PRESSURE_FLOOR!r} : acc)   /* pressures floored, */
                           : hh_unsubnormal(acc);                  /* the components' states not subnormal */
        bad += acc - acc;
    }}
    if (bad != 0.0)
        return 1;
    for (i = 0; i < NM; i++)
        m1[i] = m[i];
    project(y1, m1, u, P);
    return 0;
}}

/* (y, m) := (y1, m1): a substep taken */
HH_INLINE void take(double *y, int64_t *m, const double *y1, const int64_t *m1)
{{
    int i;
    for (i = 0; i < NY; i++)
        y[i] = y1[i];
    for (i = 0; i < NM; i++)
        m[i] = m1[i];
}}

/* One step of h with tableau tab under the inputs u, the hybrid step of SPEC §6 (hybrid.c's rule for any
 * circuit): a (sub)step; when a guard crosses inside it, the substep again to the crossing's instant, the
 * transition there, and on in the new modes; at most HH_MAX_EVENTS events a step (then the last crossing's
 * transition at the step's end). Returns 0, 1 when the state went non-finite, 2 when h is not the step its
 * delay lines were sized for (hc_init). */
HH_INLINE int one_step(const hh_tableau *tab, double h, double *y, int64_t *m, const double *u_in, const double *P,
                        int *events)
{{
    double y1[NY], sc[NSC], theta, t_left = h, hs = h;
    int64_t m1[NM];
    int pending = -1, n_events = 0, it, g;
{chr(10).join(step_inputs)}
    for (it = 0; it < 2 * HH_MAX_EVENTS + 1; it++) {{
        if (substep(tab, hs, y, m, u, P, sc, it == 0, y1, m1))   /* (the first computes sc, at y and h) */
            return 1;
        if (pending >= 0) {{                 /* at a located event: its transition, on in the new mode */
            take(y, m, y1, m1);
            transition(pending, y, m, u, P);
            project(y, m, u, P);
            pending = -1;
            t_left -= hs;
            hs = t_left;
            if (t_left <= 1e-12 * h)
                break;
            continue;
        }}
        g = first_crossing(y, y1, m, u, P, &theta);
        if (g < 0) {{
            take(y, m, y1, m1);
            break;
        }}
        if (++n_events > HH_MAX_EVENTS) {{   /* the budget spent: the step taken, the transition at its end */
            take(y, m, y1, m1);
            transition(g, y, m, u, P);
            project(y, m, u, P);
            break;
        }}
        if (theta <= 0.0) {{                 /* crossed at the start already: the transition now, the substep again */
            transition(g, y, m, u, P);
            project(y, m, u, P);
            continue;
        }}
        pending = g;                         /* the substep again, to the crossing (y1, m1 not taken) */
        hs = theta * t_left;
    }}
    *events = n_events;
    return 0;
}}

/* The step compiled without GCC's vectorizer (scalar code, the same results: no reassociation either way).
 * Measured (benchmarks/paper_circuit_c.py): the paper's circuit 108.1 ns a step against the core's 107.3, in
 * other runs +0.3 and +1.5 % (vectorized: 116.5 against 109.2); `hydrohil bench`-style runs of the seven
 * example circuits: five faster by 1-9 %, lift_platform 10 % and two_cylinders 3 % slower, the sum 1.7 % less
 * (the vectorized step has fewer instructions but runs slower; where the time goes was not located further). */
#if defined(__GNUC__) && !defined(__clang__) && defined(__has_attribute)
#if __has_attribute(optimize)     /* (the package's -ffp-contract=off said again: no fused multiply-add anywhere) */
#define HC_STEP_CODE __attribute__((optimize("no-tree-vectorize", "fp-contract=off")))
#endif
#endif
#ifndef HC_STEP_CODE
#define HC_STEP_CODE
#endif

/* one step with the tableau of `method`, a constant in each case (the compiler specialises the step to it) */
HC_STEP_CODE static int method_step(int method, double h, double *y, int64_t *m, const double *u, const double *P,
                                    int *events)
{{
    switch (method) {{
    case HH_EULER: return one_step(&HH_TABLEAUS[HH_EULER], h, y, m, u, P, events);
    case HH_HEUN: return one_step(&HH_TABLEAUS[HH_HEUN], h, y, m, u, P, events);
    case HH_RK4: return one_step(&HH_TABLEAUS[HH_RK4], h, y, m, u, P, events);
    default: return one_step(&HH_TABLEAUS[HH_RK3], h, y, m, u, P, events);
    }}
}}

/* The hybrid model behind the core's loop and rig (loop.c's HH_MODEL_GENERATED: hh_model_step_fn,
 * hh_model_friction_fn; the paper's circuit in the core's layout, generated_model.generated_hybrid_model): its
 * context an hc_core_ctx. Each call takes the loop's parameters (pairs (the loop's p slot, the circuit's P slot);
 * a derived value the product of three of them and a constant: a weight), its state (the loop's state i is the
 * circuit's at[i]; the circuit's delay line, of no delay, keeps its own memory) and its three modes (travel and
 * friction: the cylinder's one mode, cyl_of; the spool: the valve's); a step takes the loop's spool input ud
 * (its delay line's) as the input `command`, and gives back the state, the modes and the events (< 0: a state
 * not finite). */
static void core_in(hc_core_ctx *c, const double *y, const int64_t *m, const double *p)
{{
    int64_t i;
    for (i = 0; i < c->npmap; i++)
        c->P[c->pmap[2 * i + 1]] = p[c->pmap[2 * i]];
    for (i = 0; i < c->nwmap; i++)
        c->P[c->wmap[4 * i]] = p[c->wmap[4 * i + 1]] * p[c->wmap[4 * i + 2]] * p[c->wmap[4 * i + 3]] * c->wc[i];
    for (i = 0; i < c->n; i++)
        c->yc[c->at[i]] = y[i];
    c->mc[c->cyl_mode] = c->cyl_of[m[HH_M_TRAVEL] * c->nfriction + m[HH_M_FRICTION]];
    c->mc[c->valve_mode] = m[HH_M_SPOOL];
}}

/* the loop's state and modes of the circuit's (core_in's inverse) */
HH_INLINE void core_out(const hc_core_ctx *c, double *y, int64_t *m)
{{
    int64_t i, cyl = c->mc[c->cyl_mode];
    for (i = 0; i < c->n; i++)
        y[i] = c->yc[c->at[i]];
    m[HH_M_TRAVEL] = c->travel_of[cyl];
    m[HH_M_FRICTION] = c->friction_of[cyl];
    m[HH_M_SPOOL] = c->mc[c->valve_mode];
}}

int hc_core_hybrid_step(void *ctx, double *y, int64_t *m, const double *p, double ud, double h)
{{
    hc_core_ctx *c = (hc_core_ctx *)ctx;
    int events = 0, status;
    core_in(c, y, m, p);
    c->u[c->command] = ud;
    status = method_step(c->method, h, c->yc, c->mc, c->u, c->P, &events);
    core_out(c, y, m);
    return status ? -1 : events;
}}

double hc_core_friction(void *ctx, const double *y, const int64_t *m, const double *p)
{{
    hc_core_ctx *c = (hc_core_ctx *)ctx;
    core_in(c, y, m, p);
    return log_value(c->friction_column, 0.0, c->yc, c->mc, c->u, c->P);
}}

/* ---- Model Exchange (an FMU's: the importer's solver integrates the hybrid model): the states y[0..NY-1] and
 * their derivatives in the modes m (hc_rhs: no stiff-node form, the solver takes its own steps), the guards as
 * event indicators, the transitions at an event; the delayed inputs are the importer's values each delayed by
 * its delay (the FMU's queue, hc_me_delays). */
void hc_me_sizes(int64_t *ny, int64_t *nm, int64_t *nz, int64_t *nd)
{{
    *ny = NY;
    *nm = NM;
    *nz = NG;
    *nd = ND;
}}

/* the event indicators z[NG]: each guard's value (>= 0 while its mode holds), 1 for a guard of another mode */
void hc_me_indicators(const double *P, const double *y, const int64_t *m, const double *u, double *z)
{{
    double gv[NG + 1];
    int g;
    guard_values(y, m, u, P, gv);
    for (g = 0; g < NG; g++)
        z[g] = isinf(gv[g]) ? 1.0 : gv[g];
}}

/* the state and modes changed by (y, m) -> (y0, m0)? */
HH_INLINE int me_changed(const double *y, const int64_t *m, const double *y0, const int64_t *m0)
{{
    int i;
    for (i = 0; i < NY; i++)
        if (y[i] != y0[i])
            return 1;
    for (i = 0; i < NM; i++)
        if (m[i] != m0[i])
            return 1;
    return 0;
}}

/* An event (a crossing the solver located, a step's end where one went unseen, the start): the projections (a
 * spool at its end), then the transition of the first guard crossed (< 0) and on in the new modes, at most
 * HH_MAX_EVENTS (hybrid.c's budget, one_step's rule); returns 1 when the state or a mode changed. */
int hc_me_event(const double *P, double *y, int64_t *m, const double *u)
{{
    double y0[NY], gv[NG + 1];
    int64_t m0[NM];
    int i, n, g;
    for (i = 0; i < NY; i++)
        y0[i] = y[i];
    for (i = 0; i < NM; i++)
        m0[i] = m[i];
    project(y, m, u, P);
    for (n = 0; n < HH_MAX_EVENTS; n++) {{
        guard_values(y, m, u, P, gv);
        for (g = 0; g < NG && !(gv[g] < 0.0); g++)
            ;
        if (g == NG)
            break;
        transition(g, y, m, u, P);
        project(y, m, u, P);
    }}
    return me_changed(y, m, y0, m0);
}}

/* an event due at the end of a solver's step: a guard crossed that the solver did not locate, or a projection
 * that moves the state (a spool past its end) */
int hc_me_step_event(const double *P, const double *y, const int64_t *m, const double *u)
{{
    double yy[NY], gv[NG + 1];
    int64_t mm[NM];
    int i, g;
    for (i = 0; i < NY; i++)
        yy[i] = y[i];
    for (i = 0; i < NM; i++)
        mm[i] = m[i];
    project(yy, mm, u, P);
    if (me_changed(yy, mm, y, m))
        return 1;
    guard_values(y, m, u, P, gv);
    for (g = 0; g < NG; g++)
        if (gv[g] < 0.0)
            return 1;
    return 0;
}}

/* the delayed inputs: ND of them, the input each delays (idx) and its delay [s] (tau) */
int64_t hc_me_delays(const double *P, int64_t *idx, double *tau)
{{
    int d;
    for (d = 0; d < ND; d++) {{
        idx[d] = DELAYED[d];
        tau[d] = delay_time(d, P);
    }}
    return ND;
}}

/* The same behind the core's loop (the paper's rig's FMU: its state, modes and parameters in the core's layout,
 * the valve's input ud): the derivatives, the event indicators, an event, a step's end. */
void hc_core_me_derivatives(void *ctx, const double *y, const int64_t *m, const double *p, double ud, double *dy)
{{
    hc_core_ctx *c = (hc_core_ctx *)ctx;
    double dyc[NY];
    int64_t i;
    core_in(c, y, m, p);
    c->u[c->command] = ud;
    hc_rhs(c->P, c->yc, c->mc, c->u, dyc);
    for (i = 0; i < c->n; i++)
        dy[i] = dyc[c->at[i]];
}}

void hc_core_me_indicators(void *ctx, const double *y, const int64_t *m, const double *p, double ud, double *z)
{{
    hc_core_ctx *c = (hc_core_ctx *)ctx;
    core_in(c, y, m, p);
    c->u[c->command] = ud;
    hc_me_indicators(c->P, c->yc, c->mc, c->u, z);
}}

int hc_core_me_event(void *ctx, double *y, int64_t *m, const double *p, double ud)
{{
    hc_core_ctx *c = (hc_core_ctx *)ctx;
    int changed;
    core_in(c, y, m, p);
    c->u[c->command] = ud;
    changed = hc_me_event(c->P, c->yc, c->mc, c->u);
    core_out(c, y, m);
    return changed;
}}

int hc_core_me_step_event(void *ctx, const double *y, const int64_t *m, const double *p, double ud)
{{
    hc_core_ctx *c = (hc_core_ctx *)ctx;
    core_in(c, y, m, p);
    c->u[c->command] = ud;
    return hc_me_step_event(c->P, c->yc, c->mc, c->u);
}}

/* What a loop's pressure transducers read of the log row v of step k (SPEC §10; sensors.c's model, the rig's):
 * press = [n, full scale, resolution, noise, its stream's place in rng, the step h, nf, then n pairs (slot,
 * column), then nf fault rows of HC_PRESS_FAULT doubles]: out[slot] the reading of v[column] (slot 0, 1: its
 * load cylinder's two chambers, 2: the supply's node, 3: the tank's; NaN where it reads none), plus the noise
 * times a normal sample of its own stream, the n drawn at once (the rig's draw of its four transducers p1, p2,
 * ps, pt, when a loop reads all four: the same numbers); full scale 0: the pressures themselves. A fault row
 * (type as hc_sensed's, first step, step after the last, a, b, start [s], slot, its stream's place in rng,
 * memory) acts on the steps k_first <= k < k_end on the pressure of its slot before the transducer, the faults
 * of a slot in their order (the rig's, rig.c: sense): an offset a + drift b*(t - start), an added noise of
 * standard deviation a, stuck at its first step's value (memory; NaN until then and after), a dropout (0).
 * Returns 1 when a transducer's reading was clipped to its range (the rig's SATURATED), else 0. */
enum {{ HC_PRESS_HEAD = 7, HC_PRESS_FAULT = 9 }};

int hc_pressures_read(const double *v, double *press, void *rng, int64_t k, double *out)
{{
    hh_rng *r = (hh_rng *)rng;
    double z[4] = {{0.0, 0.0, 0.0, 0.0}}, t = (double)k * press[5], *faults;
    int i, f, n = (int)press[0], nf = (int)press[6], saturated = 0, any = 0;
    faults = press + HC_PRESS_HEAD + 2 * n;
    for (i = 0; i < 4; i++)
        out[i] = NAN;
    if (press[3] > 0.0 && r)
        hh_rng_normals(&r[(int)press[4]], n, z);
    for (i = 0; i < n; i++) {{
        int slot = (int)press[HC_PRESS_HEAD + 2 * i];
        double p = v[(int64_t)press[HC_PRESS_HEAD + 1 + 2 * i]];
        for (f = 0; f < nf; f++) {{
            double *F = faults + HC_PRESS_FAULT * f;
            if ((int)F[6] != slot)
                continue;
            if ((double)k < F[1] || (double)k >= F[2])
                F[8] = NAN;                         /* (a window that ends lets go) */
            else
                p = sensor_fault(p, F, t, &F[8], r ? &r[(int)F[7]] : 0);
        }}
        out[slot] = press[1] > 0.0 ? pressure_reading(p, press[1], press[2], press[3] * z[i], &saturated) : p;
        any |= saturated;
    }}
    return any;
}}

/* What the loop's transducers read of a run logged every `every` steps (rows v of NLOG columns): hc_pressures_read
 * of each row into out (4 per row), the readings of the steps between rows (their noise draws, a fault's first
 * reading) of the row's values too and not kept (exact when every row is logged). */
void hc_pressures_rows(const double *v, int64_t rows, int64_t every, double *press, void *rng, double *out)
{{
    double skip[4];
    int64_t i, j;
    for (i = 0; i < rows; i++) {{
        hc_pressures_read(v + i * NLOG, press, rng, i * every, out + 4 * i);
        if (i + 1 < rows)
            for (j = 1; j < every; j++)
                hc_pressures_read(v + i * NLOG, press, rng, i * every + j, skip);
    }}
}}

/* n steps of h with the core's tableau `method`; u: NU inputs per step (held over it), n + 1 rows (the last:
 * the last log row's, as the drive gives it at t_n); a row every `every` steps from step 0 (the state before
 * the step). Closed loop (ctl not NULL, the core's controller law,
 * control.c): at each step k the controller reads log column `meas` of the state at t_k (under the command
 * of step k-1; through the sensor, hc_sensed) and sets input `cmd` of step k (written into u) for the reference
 * ref[k] (slope dref[k]); rng: its noise generators (hc_sensed's, hc_pressures_read's); `sign` -1: a
 * reverse-acting loop (the law on -ref, -dref and the signal's negative, so
 * that a larger command lowers the signal; 1: direct, exact). path (not NULL: the scenario's network faults,
 * an hh_path of packets of one value): the controller's command goes through it (link.c: network faults, then
 * the watchdog) as to a plant over the network: the last one that arrived drives the step, 0 in the watchdog's
 * safe state (its "hold": the path's P law on the measured signal's truth, hh_path_apply_held), negated under a
 * command_inversion, saturated to the input's range [lo, hi]; sent[k] (when not
 * NULL, n + 1 of them): what the controller sent for step k (sent[n]: the last row's, not sent). press (not NULL: a loop reading its load cylinder's chambers,
 * and the supply's and the tank's pressures when it names them; hc_pressures_read's table): the law reads the
 * chambers as read too. command (not NULL, ctl NULL: a user's controller, called back with command_ctx) gives
 * step k's command from the log row of step k, the signal as sensed and the pressures as read (p1, p2, ps, pt;
 * NaN: not read; saturated: one was clipped) in place of the core's law; NaN: it failed (3 returned).
 * seen_log (not NULL): per row the ND delayed inputs of its step as the components see them (the last row's as
 * its line would give it); events_log (not NULL): per row the events located in the steps since the last row
 * (the core's log columns ud and events); watchdog_log (not NULL, with a path): per step (n + 1) 1 where the
 * command path's watchdog held the loop's command in its safe state (the last step: the step before's).
 * Returns 0, or 1 when the state went non-finite, 2 when h is not the step the state was made for (hc_init), 3
 * when the command callback failed, 4 when a state left its physical range (hc_unphysical), 5 when the progress
 * callback (not NULL: called with progress_ctx before every 4096th step, from step 0) returned non-zero. cols
 * (not NULL): each row holds only the ncols log columns cols[], in that order (a run that reads a few: the rest
 * not computed), else all NLOG (rows
 * so far written, *rows set; *steps (not NULL): the steps taken, the failed one included: its end is where the
 * run stopped). */
typedef double (*hc_command_fn)(void *ctx, int64_t k, const double *row, double sensed, double p1, double p2,
                                double ps, double pt, int saturated);
typedef int (*hc_progress_fn)(void *ctx, int64_t k);

int hc_run(const double *P, double *y, int64_t *m, int method, double h, int64_t n, int64_t every,
           double *u, double *log, int64_t *rows, const void *ctl, void *ctl_state, const double *ref,
           const double *dref, int64_t meas, int64_t cmd, double *sensor, void *rng, double sign, void *path,
           double lo, double hi, double *sent, double *press, void *command, void *command_ctx,
           double *seen_log, double *events_log, double *watchdog_log, int64_t *steps, void *progress,
           void *progress_ctx, const int64_t *cols, int64_t ncols)
{{
    double seen[NLOG], held = 0.0, events = 0.0;
    int64_t step, row = 0, i, next_row = 0;
    int64_t copied[NLOG], of_state[NLOG], modes[NLOG], computed[NLOG], nc = 0, nmc = 0, ncc = 0;
    int ev = 0, split = cols && ncols <= NLOG, meas_state = meas >= 0 && meas < NLOG ? LOG_STATE[meas] : -1;
    for (i = 0; split && i < ncols; i++) {{   /* the columns asked for: a state's copied, a mode's converted, */
        int64_t j = cols[i];                  /* the others computed (log_value) */
        if (j >= 0 && j < NLOG && LOG_STATE[j] >= 0) {{
            copied[nc] = i;
            of_state[nc++] = LOG_STATE[j];
        }} else if (j >= LOG_MODES && j < NLOG)
            modes[nmc++] = i;
        else
            computed[ncc++] = i;
    }}
    for (step = 0; step <= n; step++) {{
        double *uk = u + step * NU;
        if (progress && (step & 4095) == 0 && ((hc_progress_fn)progress)(progress_ctx, step)) {{
            *rows = row;                  /* (stopped from outside: a Ctrl-C in the progress callback) */
            if (steps)
                *steps = step;
            return 5;
        }}
        if (ctl || command) {{   /* it measures under the command last applied (step 0: as set) */
            double c, sensed, pr[4] = {{0.0, 0.0, NAN, NAN}};
            int saturated = 0;
            if (step > 0)
                uk[cmd] = uk[cmd - NU];
            else
                held = uk[cmd];           /* (the command that holds the piston until one arrives) */
            if (command)                  /* (a user's controller is handed the whole row: its status bits) */
                log_row((double)step * h, y, m, uk, P, seen);
            else {{                        /* (the law reads its signal and its transducers' columns only) */
                seen[meas] = meas_state >= 0 ? y[meas_state] : log_value(meas, (double)step * h, y, m, uk, P);
                for (i = 0; press && i < (int64_t)press[0]; i++) {{
                    int64_t col = (int64_t)press[HC_PRESS_HEAD + 1 + 2 * i];
                    seen[col] = log_value(col, (double)step * h, y, m, uk, P);
                }}
            }}
            sensed = sensor && (int)sensor[4] == 0 ? sensed_plain(seen[meas], sensor, (hh_rng *)rng)   /* (inline) */
                                                    : hc_sensed(seen[meas], sensor, rng, step);
            if (press)
                saturated = hc_pressures_read(seen, press, rng, step, pr);
            if (command) {{
                c = ((hc_command_fn)command)(command_ctx, step, seen, sensed, pr[0], pr[1], pr[2], pr[3], saturated);
                if (c != c) {{
                    *rows = row;
                    if (steps)
                        *steps = step;
                    return 3;
                }}
            }} else if (((const hh_controller *)ctl)->type == HH_CTRL_P)   /* (the P law inline: its arithmetic) */
                c = hh_p_law((const hh_controller *)ctl, sign * ref[step], sign * sensed);
            else
                c = hh_controller_update((const hh_controller *)ctl, (hh_controller_state *)ctl_state,
                                         sign * ref[step], sign * dref[step], sign * sensed, pr[0], pr[1]);
            if (path && sent)
                sent[step] = c;
            if (path && step < n) {{       /* (the last row's command: the law's, logged, not sent) */
                hh_path *pa = (hh_path *)path;
                if (hh_path_step(pa, step, 1, &c, seen[meas]))
                    held = c;
                c = hh_path_apply_held(pa, held, lo, hi, seen[meas], 0);
            }}
            if (path && watchdog_log)     /* (the safe state that decided the step's command: link.c's) */
                watchdog_log[step] = (double)((hh_path *)path)->link.active;
            uk[cmd] = c;
        }}
        if (step == next_row) {{         /* (every `every` steps: a countdown, no division a step) */
            next_row += every;
            if (seen_log && ND > 0)
                delayed_peek(y, uk, seen_log + row * ND);
            if (events_log)
                events_log[row] = events;
            events = 0.0;
            if (split) {{                  /* (only the columns asked for, in their order) */
                double *out = log + (row++) * ncols;
                for (i = 0; i < nc; i++)
                    out[copied[i]] = y[of_state[i]];
                for (i = 0; i < nmc; i++)
                    out[modes[i]] = (double)m[cols[modes[i]] - LOG_MODES];
                for (i = 0; i < ncc; i++)
                    out[computed[i]] = log_value(cols[computed[i]], (double)step * h, y, m, uk, P);
            }} else if (cols) {{
                double *out = log + (row++) * ncols;
                for (i = 0; i < ncols; i++)
                    out[i] = log_value(cols[i], (double)step * h, y, m, uk, P);
            }} else
                log_row((double)step * h, y, m, uk, P, log + (row++) * NLOG);
        }}
        if (step == n)
            break;
        int status = method_step(method, h, y, m, uk, P, &ev);
        if (!status && unphysical(P, y))
            status = 4;
        if (status) {{
            *rows = row;
            if (steps)
                *steps = step + 1;
            return status;
        }}
        events += ev;
    }}
    *rows = row;
    if (steps)
        *steps = n;
    return 0;
}}

/* The per-step interface (the FMU, a plant): one step of h with the core's tableau `method` under the inputs
 * u (h: the step the state was made for, hc_init; 2 otherwise, nothing done; hc_run's other codes); a log row
 * of the state at t. */
int hc_step(const double *P, double *y, int64_t *m, const double *u, int method, double h)
{{
    int events, status = method_step(method, h, y, m, u, P, &events);
    return !status && unphysical(P, y) ? 4 : status;
}}

void hc_row(const double *P, const double *y, const int64_t *m, const double *u, double t, double *row)
{{
    log_row(t, y, m, u, P, row);
}}
"""
    return text, lay


def _rhs_lines(c: Circuit, lay: Layout, emits, nodes: dict, *, reference: bool,
               start: list | None = None) -> list[str]:
    """The body of a right-hand side: the components' locals, the components' states' derivatives (the
    reference's where it has its own), their flows, then each state node's sum, volume and capacitance, in netlist
    order. (The derivatives before the flows, as the core's hybrid_rhs: a friction's exp starts first and the
    flows run while it completes; flows first left each stage waiting on it, the paper's step 3 % slower.)
    The hybrid model's node rate is the stiff-node form of hc_node.h with the step's constants sc (c = 1: the
    plain rate, bit for bit): its flows' rates with the pressures held use the derivatives above. ``nodes``:
    :func:`_node_terms`; ``start`` (:func:`_coupled_pairs`): the constants sc computed first, from the same flows'
    conductances and these couplings (rhs_start)."""
    rhs = []
    assigned = set(range(len(c.state_nodes)))
    for comp, e in emits:
        rhs += _pre_lines(comp, e)
    for comp, e in emits:
        derivatives = {**e.derivatives, **e.reference} if reference else e.derivatives
        for state, expr in derivatives.items():
            j = lay.states.index(f"{comp.name}.{state}")
            assigned.add(j)
            rhs.append(f"    dy[{j}] = {expr};   /* {comp.name}.{state} */")
    for comp, e in emits:
        rhs += _flow_lines(comp, e, reference, start is not None)
    # a state without a derivative is constant (a circuit without states has one): each written once, no loop
    rhs += [f"    dy[{j}] = 0.0;" for j in range(max(len(lay.states), 1)) if j not in assigned]
    for i, node in enumerate(c.state_nodes):            # each node's volume, bulk modulus, capacitance: once
        _, volume, beta, extra, g, _ = nodes[node]
        rhs.append(f"    const double vol_{i} = {volume}, beta_{i} = {beta}, cap_{i} = {extra};   /* {node} */")
        rhs.append(f"    (void)cap_{i};")
        if start is not None:
            rhs.append(f"    const double g_{i} = {g};")
    if start is not None:
        for i, node in enumerate(c.state_nodes):
            rhs.append(f"    hc_stiff_first(g_{i}, vol_{i}, beta_{i}, cap_{i}, h, sc + {3 * i});   /* {node} */")
        for i, j, slope, name in start:
            rhs.append(f"    hc_stiff_pair({slope}, h, sc + {3 * i}, sc + {3 * j});   /* {name} */")
        for i, node in enumerate(c.state_nodes):
            rhs.append(f"    hc_stiff_last(g_{i}, sc + {3 * i});   /* {node} */")
    for i, node in enumerate(c.state_nodes):
        q, _, _, extra, _, rate = nodes[node]
        c_i = "1.0" if reference else f"sc[{3 * i}]"
        law = (f"{'' if reference else c_i + ' * '}hc_node_rate({q}, vol_{i}, beta_{i}, cap_{i})" if extra != "0.0"
               else f"hc_node_rate_oil({c_i}, {q}, vol_{i}, beta_{i})")   # (oil alone: one division fewer)
        rhs.append(f"    dy[{i}] = {law};   /* {node} */")
        if reference:
            continue
        if rate != "0.0":
            rhs.append(f"    if (sc[{3 * i + 1}] != 0.0)   /* stiff: Pq moves with the flows */")
            rhs.append(f"        dy[{i}] += sc[{3 * i + 1}] * ({rate});")
    return rhs


def _pre_lines(comp, e) -> list[str]:
    """A component's locals as C constants (v_<component>_<name>)."""
    return [f"    const double v_{_ident(comp.name)}_{name} = {expr};\n    (void)v_{_ident(comp.name)}_{name};"
            for name, expr in e.pre]


def _flow_lines(comp, e, reference: bool = False, start: bool = False) -> list[str]:
    """A component's flows as C constants (q_<component>_<j>; ``reference``: the continuous reference's,
    Emit.reference_flows where it has them; ``start``: rhs_start's, a square-root law's conductance computed with
    its flow, g_q_<component>_<j>, :func:`_fused_law`)."""
    lines = []
    flows = e.reference_flows if reference and e.reference_flows is not None else e.flows
    for j, (a, b, expr, slope, _) in enumerate(map(_flow, flows)):
        var, law = f"q_{_ident(comp.name)}_{j}", _fused_law(expr, slope) if start else None
        if law is not None:
            lines.append(f"    double g_{var};")
            expr = f"hc_sqrt_law_g({law}, &g_{var})"
        lines.append(f"    const double {var} = {expr};   /* {comp.name}: {a or 'out'} -> {b or 'out'} */")
        lines.append(f"    (void){var};")
    return lines


def _in_range(v: str, lo: str, hi: str) -> str:
    """C that is true where v lies in [lo, hi] (false for NaN): a range symmetric about 0 (lo is -hi of a single
    term, or -(hi)) as fabs(v) <= hi (the same truth for every v, NaN too; one comparison, issue #29)."""
    symmetric = lo == f"-({hi})" or (lo == f"-{hi}" and re.fullmatch(r"[\w.\[\]]+", hi) is not None)
    return f"fabs({v}) <= {hi}" if symmetric else f"{lo} <= {v} && {v} <= {hi}"


def _fused_law(expr: str, slope: str | None) -> str | None:
    """The arguments of a flow that is hc_sqrt_law(ARGS) whose conductance is hc_sqrt_law_slope(ARGS), or None:
    rhs_start computes the two at once (hc_sqrt_law_g: one square root, the same bits; issue #29)."""
    head = "hc_sqrt_law("
    if slope is None or not expr.startswith(head) or slope != "hc_sqrt_law_slope(" + expr[len(head):]:
        return None
    depth = 0
    for i, ch in enumerate(expr):
        depth += (ch == "(") - (ch == ")")
        if depth == 0 and ch == ")":
            return expr[len(head):i] if i == len(expr) - 1 else None
    return None


def _conductance(var: str, expr: str, slope: str) -> str:
    """The C of a flow's conductance in rhs_start: the fused law's g_<var> (:func:`_fused_law`), else its own."""
    return f"g_{var}" if _fused_law(expr, slope) is not None else slope


def _flow(flow: tuple) -> tuple:
    """A flow of Emit.flows as (from port, to port, C flow, conductance or None, rate or None)."""
    return (*flow, None, None)[:5]


def _coupled_pairs(c: Circuit, emits) -> list[tuple[int, int, str, str]]:
    """(node i, node j, conductance, name) of each flow between two pressure nodes (hc_node.h's coupling)."""
    out = []
    for comp, e in emits:
        for j, (a, b, expr, slope, _) in enumerate(map(_flow, e.flows)):
            ends = [comp.ports[p] for p in (a, b) if p is not None]
            if slope is not None and len(ends) == 2 and ends[0] != ends[1] and all(n in c.state_nodes for n in ends):
                out.append((c.state_nodes.index(ends[0]), c.state_nodes.index(ends[1]),
                            _conductance(f"q_{_ident(comp.name)}_{j}", expr, slope),
                            f"{comp.name}: {ends[0]} - {ends[1]}"))
    return out


def _node_terms(c: Circuit, lay: Layout, emits) -> dict:
    """Per state node: (its flows' sum in, its volume, its oil's bulk modulus, its extra capacitance, its
    conductance, its flows' rate in with the pressures held), C expressions."""
    qin, g, rate = ({n: [] for n in c.state_nodes} for _ in range(3))
    by_speed: dict = {n: {} for n in c.state_nodes}     # node -> speed -> its factors (summed, then times it)
    cap, vol = {n: [] for n in c.state_nodes}, {n: [] for n in c.state_nodes}
    beta = {n: f"P[{lay.slot['fluid.bulk_modulus']}]" for n in c.state_nodes}
    for comp, e in emits:
        for port, expr in e.bulk_modulus:          # (a node's own oil: eq 21 of a chamber on it)
            if comp.ports[port] in beta:
                beta[comp.ports[port]] = expr
    for comp, e in emits:
        for j, (a, b, expr, slope, drift) in enumerate(map(_flow, e.flows)):
            var = f"q_{_ident(comp.name)}_{j}"
            for port, sign in ((a, "-"), (b, "+")):
                if port is not None and comp.ports[port] in qin:
                    node = comp.ports[port]
                    qin[node].append(f"{sign} {var}")
                    if slope is not None:                   # (rhs_start's: a square-root law's with its flow)
                        g[node].append(f"+ {_conductance(var, expr, slope)}")
                    if isinstance(drift, tuple):             # (factor, speed): the factors of one speed summed
                        factor, speed = drift
                        if speed not in by_speed[node]:
                            by_speed[node][speed] = []
                            rate[node].append(speed)            # (its place: its first term's)
                        by_speed[node][speed].append(f"{sign} {factor}")
                    elif drift is not None:
                        rate[node].append(f"{sign} {drift}")
        for port, expr in e.capacitance:
            if comp.ports[port] in cap:
                cap[comp.ports[port]].append(expr)
        for port, expr in e.volume:
            if comp.ports[port] in vol:
                vol[comp.ports[port]].append(expr)
    for node, groups in by_speed.items():
        rate[node] = [f"+ ({' '.join(groups[t])}) * {t}" if t in groups else t for t in rate[node]]
    return {node: (" ".join(qin[node]) or "0.0",
                   " + ".join([f"P[{lay.slot[f'node.{node}.volume']}]", *vol[node]]), beta[node],
                   " + ".join(cap[node]) or "0.0", " ".join(g[node]) or "0.0", " ".join(rate[node]) or "0.0")
            for node in c.state_nodes}


def _mode_update(comp, e, lay: Layout) -> str:
    """The C of a component's mode update after a step: its own, or its mode set to its function of the state."""
    if e.mode_update:
        return e.mode_update
    return f"m[{lay.modes.index(comp.name + '.mode')}] = {e.mode_of_state};"


def _initial(c: Circuit, lay: Layout, node: str) -> str:
    """A node's initial guess: its [initial] pressure, else the lowest fixed pressure (driven ones: their value at
    step 0 is not known here; the tank's 0 when every fixed pressure is driven)."""
    if node in c.initial:
        return repr(float(c.initial[node]))
    fixed = [(c.components[comp].values[key], n) for n, (comp, key) in c.fixed.items()
             if not math.isnan(c.components[comp].values[key])]
    return _pressure(lay, min(fixed)[1]) if fixed else "0.0"


def _ident(name: str) -> str:
    return "".join(ch if ch.isalnum() else "_" for ch in name)
