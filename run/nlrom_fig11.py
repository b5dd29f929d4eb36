#!/usr/bin/python3
"""Seed 003 Fig. 11: the von Mises stress fields of the full model and of the three reduced models
at r = 25 (POD, CB with POD filtering, CB + modal derivatives), at t_max = the second peak of the
excitation (300 N at LE along y, 2,000 rad/s: t = 5 pi / (2 omega) = 3.93 ms), with `morse stress`
(-fom for the full model). docs/nlrom.md, "Fig. 11".

  /usr/bin/python3 run/nlrom_fig11.py [--mesh meshes/blade_coarse.msh] [--out out/nlrom_fig11]
      [--dt 2.5e-5] [--fom-dt 1e-4]

The full model and the reduced models are integrated with the energy-conserving implicit scheme
(`-fom_scheme energy`, `-sim_scheme energy`) at the steps given. Prints the largest nodal von Mises
stress of each model with its distance from LE, the same away from LE, and each model's I against
the full model; writes OUT/fig11.png (four panels, one colour scale, clipped at the full model's
largest stress farther than 10 mm from LE, so that the loaded node does not set the scale).
About 2 minutes on 2 cores for the coarse blade.
"""
import argparse
import math
import os
import subprocess
import sys

import h5py
import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
OMEGA, AMPLITUDE = 2000.0, 300.0


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--mesh", default=os.path.join(ROOT, "meshes", "blade_coarse.msh"))
    p.add_argument("--out", default=os.path.join(ROOT, "out", "nlrom_fig11"))
    p.add_argument("--dt", type=float, default=2.5e-5, help="reduced models' step [s]")
    p.add_argument("--fom-dt", type=float, default=2.5e-5, help="full model's step [s]")
    p.add_argument("--morse", default=os.path.join(ROOT, "build", "morse"))
    p.add_argument("--reuse", action="store_true", help="skip the runs whose output file exists (resume)")
    a = p.parse_args()
    os.makedirs(a.out, exist_ok=True)
    env = dict(os.environ, OMP_NUM_THREADS="1", OPENBLAS_NUM_THREADS="1",
               OMPI_ALLOW_RUN_AS_ROOT="1", OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1")

    def morse(ranks, args, what, output=None):
        if a.reuse and output and os.path.exists(output):
            print("  %s: reused %s" % (what, output), flush=True)
            return ""
        cmd = ["mpirun", "--oversubscribe", "-n", str(ranks), a.morse] + [str(x) for x in args]
        print("  %s" % what, flush=True)
        r = subprocess.run(cmd, env=env, capture_output=True, text=True)
        with open(os.path.join(a.out, "morse.log"), "a") as fh:
            fh.write("$ %s\n%s%s" % (" ".join(cmd), r.stdout, r.stderr))
        if r.returncode != 0:
            sys.exit("morse failed (%s): %s" % (what, (r.stderr or r.stdout).strip().splitlines()[-1]))
        return r.stdout

    f = lambda name: os.path.join(a.out, name)
    model = ["-mesh", os.path.abspath(a.mesh), "-clamp", "root"]
    load = ["-load_sets", "LE", "-load_LE_dir", "y", "-load_LE_amplitude", AMPLITUDE, "-load_LE_omega", OMEGA]
    t_train, t_test = 2 * math.pi / OMEGA, 10 * 2 * math.pi / OMEGA
    t_max = 5 * math.pi / (2 * OMEGA)  # the second peak of sin(omega t)
    damp_fom = ["-fom_damping_modal", "5e-4", "-fom_damping_modes", "10"]
    fom_train, fom_test = f("fom_train.h5"), f("fom_test.h5")
    morse(2, ["fom"] + model + load + damp_fom + ["-fom_scheme", "energy", "-fom_dt", a.fom_dt, "-fom_tfinal", t_train,
                                                 "-fom_snapshot_every", 1, "-fom_monitor", "LE,tip", "-out", fom_train],
          "full model, training run (one period)", fom_train)
    morse(2, ["fom"] + model + load + damp_fom + ["-fom_scheme", "energy", "-fom_dt", a.fom_dt, "-fom_tfinal", t_test,
                                                 "-fom_snapshot_every", max(1, round(1e-4 / a.fom_dt)),
                                                 "-fom_monitor", "LE,tip", "-out", fom_test],
          "full model, test run (ten periods)", fom_test)
    r = 25
    damp = ["-nlrom_damping_modal", "5e-4", "-nlrom_damping_modes", "10"]
    bases = {
        "POD": ["-nlrom_basis", "pod", "-nlrom_num_pod", r - 3, "-nlrom_snapshots", fom_train],
        "CB with POD filtering": ["-nlrom_basis", "cb", "-nlrom_num_fixed_modes", r - 3, "-nlrom_snapshots",
                                  fom_train, "-nlrom_filter_pod", 10],
        "CB + modal derivatives": ["-nlrom_basis", "cbmd", "-nlrom_num_fixed_modes", 4, "-nlrom_num_derivatives",
                                   r - 7] + load + ["-nlrom_training_tfinal", t_train],
    }
    stress = {"full model": f("stress_fom.h5")}
    morse(2, ["stress"] + model + ["-fom", fom_test, "-stress_time", t_max, "-out", stress["full model"]],
          "stress of the full model", stress["full model"])
    indicator = {}
    for k, (name, extra) in enumerate(bases.items()):
        rom, sim = f("rom_%d.h5" % k), f("sim_%d.h5" % k)
        morse(2, ["nlrom"] + model + ["-boundary", "LE"] + damp + extra + ["-out", rom], "nlrom: %s, r = %d" % (name, r),
              rom)
        morse(1, ["simulate", "-rom", rom] + load + ["-sim_scheme", "energy", "-sim_dt", a.dt, "-sim_tfinal",
                                                     t_test + a.dt, "-sim_monitor", "LE,tip", "-out", sim],
              "simulate: %s" % name, sim)
        with h5py.File(sim, "r") as h:
            compared = "/compare/I" in h
        if not compared:
            morse(1, ["compare", fom_test, sim], "compare: %s" % name)
        with h5py.File(sim, "r") as h:
            indicator[name] = float(h["/compare/I"][0])
        stress[name] = f("stress_%d.h5" % k)
        morse(2, ["stress"] + model + ["-rom", rom, "-sim", sim, "-stress_time", t_max, "-out", stress[name]],
              "stress: %s" % name, stress[name])
    # The largest nodal von Mises stress, at and away from LE.
    with h5py.File(fom_test, "r") as h:
        le = int(h["/fom/sets/LE/node_ids"][0])
    far_max = None
    print("\nFig. 11 (r = %d, t_max = %.4g ms):" % (r, t_max * 1e3))
    for name, path in stress.items():
        with h5py.File(path, "r") as h:
            x = h["/mesh/coordinates"][:].reshape(-1, 3)
            ids = list(h["/mesh/node_ids"][:])
            vm = h["/stress/von_mises"][0]
        d = np.linalg.norm(x - x[ids.index(le)], axis=1)
        k = int(np.argmax(vm))
        far = d > 1e-2
        kf = int(np.argmax(np.where(far, vm, -1)))
        if far_max is None:
            far_max = vm[kf]
        print("  %-24s max %8.1f MPa at %.1f mm from LE; farther than 10 mm: max %7.1f MPa at %.1f mm%s"
              % (name, vm[k] / 1e6, d[k] * 1e3, vm[kf] / 1e6, d[kf] * 1e3,
                 "" if name == "full model" else "; I = %.3f" % indicator[name]))
    labels = ["(a) reference", "(b) POD", "(c) CB with POD filtering", "(d) modal derivatives"]
    subprocess.run(["/usr/bin/python3", os.path.join(HERE, "plot_stress.py")] + list(stress.values()) +
                   ["--labels", ",".join(labels), "--vmax", "%.6g" % (far_max / 1e6), "--out", f("fig11.png"),
                    "--title", "von Mises stress at t_max = %.3f ms, r = %d" % (t_max * 1e3, r)], check=True)
    print("wrote %s" % f("fig11.png"))


if __name__ == "__main__":
    main()
