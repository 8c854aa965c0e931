"""Every fixed error of the car at once, learnt online by the filter (the simulation;
docs/method.md c.13.3).

    python scripts/car_states_simulation.py [--drives 10] [--duration 120] [--first-seed 1]

A five-radar car (``simulation/car_rig.py``) with the issue's injected errors: thrust angle 0.5 deg,
mountings +1.5 / -1.5 / +1.0 / -0.5 / -0.5 deg, clocks 0 / 15 / 30 / 45 / 60 ms, wheel scale 1% (and a
gyro offset of 0, estimated too), on drives with accelerations and turns. The filter starts every
state at 0 with its prior (scale 2%, gyro 0.5 deg/s, thrust 1 deg, yaws 2 deg with their mean held at
0 by the rig, clocks 50 ms) and runs them all online. Per state: the truth, the mean estimate at the
end over the drives, the largest error, the mean std, and whether every drive is within the
0.1 deg / 5 ms / 0.1%; and the 13 states' NEES at the end, averaged over the drives, against its 95%
band (chi-square of 12 x drives degrees of freedom: the yaws' mean is held at 0). Seeds ``--first-seed`` .. + drives - 1.

    python scripts/car_states_simulation.py --pose [--drives 2] [--duration 60] [--first-seed 1]

``--pose`` prints instead the pose's NEES (3 dof, the mean over each drive's last three quarters) with the
errors as injected, with the radars' yaw offsets or clocks alone, with neither, at half and a quarter of
their size, and with a tenth of the odometer's turn-rate noise (the filter told so): what makes the states
inconsistent (docs/method.md c.13.3).
"""

from __future__ import annotations

import argparse
import math

import numpy as np
from scipy import stats

from radarslam.simulation.car_rig import INPUT_STD, RIG, TOLERANCE, CarErrors, one_drive, pose_nees_of_drive, truth_vector

def main(argv=None) -> int:
    a = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    a.add_argument("--drives", type=int, default=10)
    a.add_argument("--duration", type=float, default=120.0)
    a.add_argument("--first-seed", type=int, default=1)
    a.add_argument("--pose", action="store_true", help="the pose's NEES under scaled errors instead")
    args = a.parse_args(argv)
    if args.pose:
        return _pose_study(args)
    truth, kinds = truth_vector(CarErrors())
    est, nees = [], []
    for s in range(args.first_seed, args.first_seed + args.drives):
        x, P = one_drive(s, args.duration)
        e = x - truth
        est.append((x, np.sqrt(np.diag(P))))
        nees.append(float(e @ np.linalg.pinv(P, rcond=1e-12, hermitian=True) @ e))
        print(f"drive {s}: NEES {nees[-1]:.1f}", flush=True)
    X = np.array([x for x, _ in est])
    S = np.array([s for _, s in est])
    names = ["wheel scale", "gyro offset", "thrust"] + [f"yaw {j}" for j in range(len(RIG))] + \
            [f"clock {j}" for j in range(len(RIG))]
    unit = {"scale": (100.0, "%"), "gyro": (180 / math.pi, "deg/s"), "thrust": (180 / math.pi, "deg"),
            "yaw": (180 / math.pi, "deg"), "time": (1e3, "ms")}
    print("\n| state | truth | mean estimate | largest error | mean std | every drive within the tolerance |")
    print("|---|---|---|---|---|---|")
    for i, (n, k) in enumerate(zip(names, kinds)):
        f, u = unit[k]
        err = np.abs(X[:, i] - truth[i])
        print(f"| {n} ({u}) | {f * truth[i]:+.3f} | {f * X[:, i].mean():+.4f} | {f * err.max():.4f} | "
              f"{f * S[:, i].mean():.4f} | {'yes' if np.all(err <= TOLERANCE[k]) else 'no'} (+-{f * TOLERANCE[k]:g}) |")
    d = len(names) - 1                       # the rig's zero mean removes one degree of freedom
    lo, hi = stats.chi2.ppf([0.025, 0.975], d * len(nees)) / len(nees)
    print(f"\nNEES of the car's states at the end (mean over {len(nees)} drives): {np.mean(nees):.2f}; "
          f"95% band [{lo:.2f}, {hi:.2f}] ({d} dof: {len(names)} states, their yaws' mean held at 0)")
    return 0


#: ``--pose``'s cases: (label, the injected errors, the odometer's white noise).
POSE_CASES = (("as injected", CarErrors(), INPUT_STD),
              ("yaw offsets alone", CarErrors().scaled(time=0.0), INPUT_STD),
              ("clocks alone", CarErrors().scaled(yaw=0.0), INPUT_STD),
              ("neither", CarErrors().scaled(yaw=0.0, time=0.0), INPUT_STD),
              ("both at half", CarErrors().scaled(0.5, 0.5), INPUT_STD),
              ("both at a quarter", CarErrors().scaled(0.25, 0.25), INPUT_STD),
              ("as injected, a tenth of the turn-rate noise", CarErrors(), (INPUT_STD[0], INPUT_STD[1] / 10)))


def _pose_study(args) -> int:
    seeds = range(args.first_seed, args.first_seed + args.drives)
    print(f"| radars' errors | {' | '.join(f'seed {s}' for s in seeds)} |")
    print(f"|---|{'---|' * len(seeds)}")
    for label, errors, std in POSE_CASES:
        nees = [pose_nees_of_drive(s, args.duration, errors, input_std=std) for s in seeds]
        print(f"| {label} | {' | '.join(f'{n[len(n) // 4:].mean():.2f}' for n in nees)} |", flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
