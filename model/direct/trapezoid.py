"""pyomo.dae has no trapezoid rule; this registers one as ``dae.trapezoid``.

Use it like any pyomo.dae discretisation::

    TransformationFactory("dae.trapezoid").apply_to(m, wrt=m.t, nfe=100)

Every first-order ``DerivativeVar`` dX/dt of a state indexed by the ContinuousSet
becomes an ordinary Var, and ``<name>_trapezoid[k]`` constraints are added for k >= 1:

    X[t_k] - X[t_{k-1}] == (t_k - t_{k-1}) / 2 * (dX[t_{k-1}] + dX[t_k])

The model's own ODE constraints (dX[t] == f(X[t], U[t])) stay active at every node,
t_0 included: with controls at the nodes this is the paper's scheme (31).

``steps``: a component indexed 1..N (a Var: a free grid) whose k-th entry replaces t_k - t_{k-1}
in every trapezoid row (the set's points then only number the nodes)::

    X[t_k] - X[t_{k-1}] == steps[k] / 2 * (dX[t_{k-1}] + dX[t_k])
"""

from __future__ import annotations

from pyomo.common.config import ConfigBlock, ConfigValue, PositiveInt
from pyomo.core import Constraint, Param, RangeSet, Var
from pyomo.core.base import Transformation, TransformationFactory
from pyomo.dae import ContinuousSet, DerivativeVar
from pyomo.dae.diffvar import DAE_Error
from pyomo.dae.misc import expand_components, generate_finite_elements


@TransformationFactory.register("dae.trapezoid", doc="Trapezoid-rule discretisation of a DAE model.")
class TrapezoidTransformation(Transformation):
    """Discretise first-order ODEs with the implicit trapezoid rule on the set's points."""

    CONFIG = ConfigBlock("dae.trapezoid")
    CONFIG.declare("nfe", ConfigValue(default=10, domain=PositiveInt, description="number of intervals"))
    CONFIG.declare("wrt", ConfigValue(default=None, description="the ContinuousSet to discretise"))
    CONFIG.declare("steps", ConfigValue(default=None, description="the steps indexed 1..N (default: the points')"))

    def _apply_to(self, model, **kwds) -> None:
        config = self.CONFIG(kwds)
        sets = [config.wrt] if config.wrt is not None else list(model.component_objects(ContinuousSet))
        for ds in sets:
            if "scheme" in ds.get_discretization_info():
                raise DAE_Error(f"ContinuousSet '{ds.name}' is already discretised")
            _uniform_points(ds, config.nfe)
            info = ds.get_discretization_info()
            info["nfe"] = len(ds) - 1
            info["scheme"] = "Trapezoid"
        expand_components(model)
        for dv in list(model.component_objects(DerivativeVar, descend_into=True)):
            for ds in sets:
                if ds in dv.get_continuousset_list():
                    _add_trapezoid(dv, ds, config.steps)


def _uniform_points(ds: ContinuousSet, nfe: int) -> None:
    """Exactly uniform points t_k = a + k (b - a) / nfe (pyomo.dae rounds to 1e-6)."""
    if len(ds) != 2:
        generate_finite_elements(ds, nfe)
        return
    a, b = ds.first(), ds.last()
    for k in range(1, nfe):
        ds.add(a + k * (b - a) / nfe)
    ds.set_changed(True)


def _add_trapezoid(dv: DerivativeVar, ds: ContinuousSet, steps=None) -> None:
    """Add the trapezoid equations for one derivative and make it a plain Var (``steps``: see the module)."""
    if dv.get_continuousset_list() != [ds] or dv.dim() != 1:
        raise DAE_Error(f"dae.trapezoid handles first derivatives of Vars indexed by one set; not '{dv.name}'")
    sv = dv.get_state_var()
    block = dv.parent_block()
    tp = _points_param(block, ds)
    n = len(ds) - 1

    def rule(_block, k):  # written with tp[k] so that Pyomo can templatise it
        step = tp[k] - tp[k - 1] if steps is None else steps[k]
        return sv[tp[k]] - sv[tp[k - 1]] == step / 2 * (dv[tp[k - 1]] + dv[tp[k]])

    block.add_component(f"{dv.local_name}_trapezoid", Constraint(RangeSet(1, n), rule=rule))
    dv.set_derivative_expression(None)
    block.reclassify_component_type(dv, Var)


def _points_param(block, ds: ContinuousSet) -> Param:
    """The set's points as an (immutable) Param indexed 0..N, shared by its derivatives."""
    name = f"{ds.local_name}_points"
    if block.find_component(name) is None:
        points = list(ds)
        block.add_component(name, Param(RangeSet(0, len(points) - 1), initialize=dict(enumerate(points))))
    return block.find_component(name)
