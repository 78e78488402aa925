"""Benchmark of the FE model update (paper section 4.2.1, Tables 4-5).

Run: ``python benchmarks/bench_update.py [--quick]``

1. One eigen-solution of the 100-element beam (200 DOF, lowest 4 modes):
   banded subspace iteration vs dense ``scipy.linalg.eigh(subset_by_index)``.
2. The whole update as the pipeline runs it: differential evolution, 5 repeats,
   exact frequency scaling (one reference solve). Wall time, best eq. (26)
   objective, mode 1, identifiable combination h*sqrt(E/rho)/L^2.
3. A naive peer in the same run: the same differential evolution, but every
   evaluation assembles the FE model and solves it (dense eigh). It is run for
   a few generations only; its time per evaluation, multiplied by the number of
   evaluations the real update used, gives the extrapolated naive wall time.
4. The point-mass path (accelerometers, 3.2 g at nodes 3 and 6), where every
   candidate needs a full eigen-solve (batched over the population).
"""

from __future__ import annotations

import argparse
import time

import numpy as np
import scipy.linalg
from scipy.optimize import differential_evolution

from ema_pipeline import fe, paper
from ema_pipeline.data import Beam, ModalParameters


def best_time(func, repeat: int = 50) -> float:
    """Best of ``repeat`` wall times in s (robust against a busy machine)."""
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        func()
        times.append(time.perf_counter() - t0)
    return min(times)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="skip the point-mass path")
    args = parser.parse_args()

    beam = Beam()
    fx = ModalParameters.from_damped(
        paper.TABLE1_FD_HZ["genuine"], paper.TABLE1_ZETA["genuine"]
    ).fn_hz

    # 1. one eigen-solution
    model = fe.assemble_beam(beam)
    t_asm = best_time(lambda: fe.assemble_beam(beam))
    t_band = best_time(lambda: fe.lowest_modes(model.K, model.M, 4, method="banded"))
    t_dense = best_time(lambda: fe.lowest_modes(model.K, model.M, 4, method="dense"))
    exact = fe.lowest_modes(model.K, model.M, 4, method="banded")[0]
    dense = scipy.linalg.eigh(model.K, model.M, subset_by_index=[0, 3], eigvals_only=True)
    print("== one FE solve, 100 elements (200 DOF), lowest 4 modes (best of 50)")
    print(f"assembly (vectorised)            {t_asm * 1e3:8.3f} ms")
    print(f"banded subspace iteration        {t_band * 1e3:8.3f} ms")
    print(f"dense eigh(subset_by_index)      {t_dense * 1e3:8.3f} ms"
          f"   (mode-1 eigenvalue differs by {abs(dense[0] / exact[0] - 1):.1e} rel.)")

    # 2. the update as the pipeline runs it
    t0 = time.perf_counter()
    res = fe.update_beam(beam, fx, n_repeats=5, seed=0)
    wall = time.perf_counter() - t0
    nfev = sum(r.n_evaluations for r in res.runs)
    print("\n== model update: differential evolution x5, exact scaling")
    print(f"wall time                        {wall:8.3f} s   ({nfev} evaluations)")
    print(f"best objective eq. (26)          {res.objective:8.5f}   "
          f"(runs: {', '.join(f'{o:.5f}' for o in res.objectives)})")
    print(f"mode 1                           {res.fn_updated_hz[0]:8.4f} Hz (paper 18.14)")
    print("updated fn                       " + ", ".join(f"{f:.2f}" for f in res.fn_updated_hz)
          + " Hz (paper Table 5: " + ", ".join(f"{f:.2f}" for f in paper.TABLE5_FN_HZ) + ")")
    print(f"{fe.IDENTIFIABLE_NAME:32s} {res.identifiable_updated:8.4f} 1/s "
          f"(initial {res.identifiable_initial:.4f}; runs spread "
          f"{np.ptp(res.identifiable_runs) / res.identifiable_updated:.1e} rel.)")
    for i, name in enumerate(res.parameter_names):
        print(f"  {name:18s} updated {res.updated[i]:12.6g}   runs min {res.run_min[i]:12.6g}"
              f"  max {res.run_max[i]:12.6g}")

    # 3. naive peer: full assembly + dense solve per evaluation, same DE settings
    def naive_objective(x: np.ndarray) -> float:
        m = fe.assemble_beam(fe.beam_with_parameters(beam, x))
        lam = scipy.linalg.eigh(m.K, m.M, subset_by_index=[0, 3], eigvals_only=True)
        return float(fe.update_objective(np.sqrt(lam) / (2 * np.pi), fx))

    bounds = list(zip(res.lower, res.upper, strict=True))
    t0 = time.perf_counter()
    part = differential_evolution(naive_objective, bounds, maxiter=3, popsize=15, tol=1e-6,
                                  rng=np.random.default_rng(0), polish=False)
    t_naive = time.perf_counter() - t0
    per_eval = t_naive / part.nfev
    print("\n== naive peer: assemble + dense eigh per evaluation (same DE)")
    print(f"measured                         {t_naive:8.3f} s for {part.nfev} evaluations"
          f" ({per_eval * 1e3:.2f} ms each)")
    print(f"extrapolated to {nfev} evaluations {per_eval * nfev:8.1f} s"
          f"   -> speed-up {per_eval * nfev / wall:.0f}x")

    # 4. point masses: full solves, batched over the population
    if not args.quick:
        pm_beam = Beam(point_masses=((beam.node_x_m(3), 0.0032), (beam.node_x_m(6), 0.0032)))
        t0 = time.perf_counter()
        pm = fe.update_beam(pm_beam, fx, n_repeats=1, seed=0)
        t_pm = time.perf_counter() - t0
        print("\n== point masses (2 x 3.2 g): batched full solves, 1 repeat")
        print(f"wall time                        {t_pm:8.3f} s   "
              f"({pm.runs[0].n_evaluations} evaluations, "
              f"{t_pm / pm.runs[0].n_evaluations * 1e3:.3f} ms each)")
        print(f"best objective eq. (26)          {pm.objective:8.5f}, mode 1 "
              f"{pm.fn_updated_hz[0]:.4f} Hz")


if __name__ == "__main__":
    main()
