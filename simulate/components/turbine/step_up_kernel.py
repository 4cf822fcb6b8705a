"""Compiled kernel of stepped-up characteristics that are not trained nets (for the exact synthetic Francis turbine):
its torque times the step-up factor, flow unchanged (see :mod:`simulate.components.turbine.step_up`). Kept apart
so that reading a plant file never imports numba."""

from __future__ import annotations

import numba

from hillchart.synthetic.francis import _synthetic_kernel


@numba.njit(cache=True)
def scaled_synthetic_kernel(params, n11, opening):
    """``params = (synthetic turbine params, factor)``: the synthetic kernel's
    ``(q11, dq11_dn11, dq11_da, m11, dm11_dn11, dm11_da)`` with the three torque entries times ``factor``."""
    q, dq_dn, dq_da, m, dm_dn, dm_da = _synthetic_kernel(params[0], n11, opening)
    factor = params[1]
    return q, dq_dn, dq_da, factor * m, factor * dm_dn, factor * dm_da
