"""lambda/qdd error distribution of ours and Pinocchio's against a 40-digit solve of
Pinocchio's KKT system (M, nle, J, gamma), over many random states (lamcheck.py extended).
Run from a checkout root with Pinocchio and mpmath installed:
`PYTHONPATH=<package> python3 scripts/spatial-lambda-accuracy.py [N]` (default 96 states)."""
import sys
sys.path.insert(0, "python/tests")
import numpy as np, pinocchio as pin, mpmath as mp
import test_spatial_pinocchio as T
mp.mp.dps = 40
N = int(sys.argv[1]) if len(sys.argv) > 1 else 96
cases = [("rhex6", "table_4_2_legs"), ("quadruped", "as_shipped")]
for case in cases:
    source, suffixes, scale, modes = T.DYNAMICS[case]
    ours, model, data = T.both(source)
    rng = np.random.default_rng(11)
    eo, ep, qo, qp, d = [], [], [], [], []
    for k in range(N):
        contacts = modes[k % len(modes)]
        q, v, tau = T.random_state(rng, model.nq, model.nv)
        J, gamma = T.contact_rows(model, data, q, v, contacts)
        out = ours.dynamics(contacts, q, v, tau)
        qdd = pin.forwardDynamics(model, data, q, v, tau, J, gamma).copy()
        lp = data.lambda_c.copy()
        M = T.pin_mass_matrix(model, data, q)
        b = pin.nonLinearEffects(model, data, q, v)
        n, m = M.shape[0], J.shape[0]
        K = mp.matrix(n + m, n + m)
        rhs = mp.matrix(n + m, 1)
        for i in range(n):
            for j in range(n):
                K[i, j] = mp.mpf(M[i, j])
            rhs[i] = mp.mpf(tau[i]) - mp.mpf(b[i])
        for i in range(m):
            for j in range(n):
                K[n + i, j] = mp.mpf(J[i, j]); K[j, n + i] = mp.mpf(J[i, j])
            rhs[n + i] = -mp.mpf(gamma[i])
        x = mp.lu_solve(K, rhs)
        lref = np.array([float(-x[n + i]) for i in range(m)])
        qref = np.array([float(x[i]) for i in range(n)])
        sc = max(1.0, np.max(np.abs(lref)))
        eo.append(np.max(np.abs(np.asarray(out.lam) - lref)) / sc)
        ep.append(np.max(np.abs(lp - lref)) / sc)
        d.append(np.max(np.abs(np.asarray(out.lam) - lp)) / max(1.0, np.max(np.abs(lp))))
        qs = max(1.0, np.max(np.abs(qref)))
        qo.append(np.max(np.abs(np.asarray(out.qdd) - qref)) / qs)
        qp.append(np.max(np.abs(qdd - qref)) / qs)
    def dist(a):
        a = np.sort(np.asarray(a))
        return f"median {np.median(a):.1e}  p90 {a[int(0.9 * (len(a) - 1))]:.1e}  max {a[-1]:.1e}"
    print(f"{'-'.join(case)} ({N} states, modes cycled)")
    print(f"  lam ours-ref: {dist(eo)}")
    print(f"  lam pin -ref: {dist(ep)}")
    print(f"  lam ours-pin: {dist(d)}")
    print(f"  qdd ours-ref: {dist(qo)}")
    print(f"  qdd pin -ref: {dist(qp)}")
    for mi, mode in enumerate(modes):
        sel = list(range(mi, N, len(modes)))
        print(f"   mode {mi}: lam ours max {max(eo[i] for i in sel):.1e}  pin max {max(ep[i] for i in sel):.1e}")
