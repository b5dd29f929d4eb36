#!/usr/bin/python3
"""Seed 003 §5 on the embedded blade: contact with the ovalized casing, with and without geometric
nonlinearity (docs/contact.md).

    /usr/bin/python3 run/contact_study.py [--mesh meshes/blade_coarse.msh] [--out out/contact_study]
        [--stages roms,single,pod,sweep,stress,diagnosis,maps,map_stress,realizations,continuation,windows] [--ranks N] [--revs 10]
        [--sweep-revs 5] [--maps linear] [--map-range 750:2190:16] [--map-refine 1] [--map-revs 200]
        [--map-dt-nonlinear 5e-7] [--rotation auto] [--stress-window 2] [--realizations 1e-12,-1e-12]
        [--sweep-linear 750:2200:10] [--sweep-nonlinear 750:2200:50] [--sweeps linear,nonlinear]
        [--pod-revs 5] [--pod-train-revs 1] [--pod-fom-dt 1e-6] [--pod-snap-every 5] [--pod-num 20]
        [--pod-trainings contact,harmonic,contact_linear] [--pod-harmonic-amplitude 300] [--pod-harmonic-omega 2000]

Every stage skips a result that is already on disk (delete it to recompute), so the study can be
stopped and resumed, and the stages can run at different times. --sliding relative|rotation sets
the friction law of every contact run (-contact_sliding; default relative, the Coulomb law on the
tip's velocity relative to the casing; rotation is the seed's, docs/contact.md "The friction
law"); a study directory holds one law, and one made before the option holds the rotation law.

  roms    CB + modal derivatives with exact tensors (the seed's choice, §5.2.1), 8 tip nodes kept
          physical (24 constraint modes): r79 = 24 + 15 + 40 (the seed's basis) and
          r89 = 24 + 20 + 45 (its convergence check), both trained as in docs/nlrom.md
          (300 N at LE in e_y, 2000 rad/s). r54 = 24 + 10 + 20 is the cheaper sweep basis.
  single  Omega = 1450 rad/s, --revs revolutions (the seed: 200): r79 nonlinear and linear (Fig. 17),
          r79 at dt and dt / 5 over 2 revolutions (Fig. 18), r89 and r54 nonlinear (Fig. 19: the
          seed's convergence check, and the fidelity of the cheaper sweep basis). With
          --single-scaled (the 60k blade, whose unscaled step is 6.8e-8 s): the maps' models instead,
          r79, r89 and r54 mass-scaled to 20 kHz (built here), turning in the maps' sense
          (--rotation), nonlinear at --map-dt-nonlinear (Fig. 18: it and a fifth of it), linear at
          the linear maps' step; two runs at a time on one rank each.
  pod     seed Figs. 20-22: the MD model r79 at 1450 rad/s over --pod-revs revolutions (the `single`
          stage's fig17_nonlinear if --pod-revs equals --revs), then for each training of
          --pod-trainings a full-order `morse fom` over --pod-train-revs revolutions with snapshots
          (contact: driven by the MD run's contact forces, -load_history; harmonic: the seed's §4
          training, 300 N at 2000 rad/s at LE, turned radial as in §5; contact_linear: the contact
          forces on the linear twin -fom_linear, a diagnosis), `morse nlrom -nlrom_basis pod`
          (24 constraint modes + --pod-num POD vectors, exact tensors: the seed's 20) and the POD ROM's
          contact run at 1450 rad/s over --pod-revs revolutions (step: 5e-8 s, or 0.9 x its critical
          step if that is smaller).
  sweep   `morse sweep` of r54, linear over --sweep-linear and nonlinear over --sweep-nonlinear
          (lo:hi:step rad/s), --sweep-revs revolutions each, on --ranks ranks (the same basis for
          both maps, so that they differ by g~ alone; r79 would cost 3.6 times more per step).
  diagnosis  why the linear maps were not physical (docs/contact.md): linear sweeps of r54 over
          --diag-range with --diag-revs revolutions each, with friction, without, and with friction
          turning the other way (-sweep_rotation negative), each with its energy balance; single runs
          at 830 rad/s (5 revolutions) with friction, without, and with every mode damped. Figure:
          run/plot_contact_diagnosis.py. About 9 minutes on 2 cores.
  maps    the seed's maps at the seed's scale (issue 28 §3): `morse sweep` of r79 made fast by
          selective mass scaling (-nlrom_mass_scaling_fmax 20000, theory §8.7: the modes above
          20 kHz moved to 20 kHz; docs/contact.md "Faster models"), --map-revs revolutions per
          speed (the seed: 200), a coarse grid --map-range refined to --map-refine rad/s where
          neighbours differ (the seed's 1 rad/s), for each of --maps (linear: step 8e-6 s;
          nonlinear: --map-dt-nonlinear, 5e-7 s), in the sense of rotation --rotation (auto: the
          leading edge leads, from the LE and TE sets of the model; positive; negative). The
          linear map takes about 15 minutes on 2 cores; a nonlinear one is a cluster job
          (run/cluster/): its predicted cost is printed first, and it resumes.
  map_stress  Fig. 25 on the maps of `maps` (issue 28): for each of --maps, the main 1B/eo8
          interaction (the highest RMS, median over the speeds within 2 rad/s, at speeds from the exact
          1B/eo8 crossing to --stress-window times it whose largest spectral line is engine order 8;
          the highest there if no speed's is), a single `morse simulate` at that speed with the map's model, sense, step
          (the speed's own, after any retry) and revolutions, then `morse stress` at the time of
          the largest radial displacement at LE (linear measure for the linear map, SVK Cauchy
          stress for the nonlinear one). The single run repeats the sweep's speed (the sweep and
          simulate give the same result), so its RMS is checked against the map's.
  realizations  how far round-off moves the linear map (issue 28): the coarse grid of the linear
          map (--map-range, --map-revs, not refined) run again with every speed multiplied by
          1 + e for each e of --realizations (a perturbation of round-off size), on the same model
          and casing. The map's own coarse-grid speeds are the realization e = 0. Prints, per speed,
          the spread of the LE RMS (largest over smallest) and the speeds where it exceeds 1.2;
          run/plot_contact_realizations.py draws them over the refined map. About a minute per
          realization on 2 cores.
  continuation  both branches of the maps (issue 28): for each of --cont-maps, `morse sweep
          -sweep_continuation up` and `down` over --cont-range (lo:hi:step rad/s) with --cont-revs
          revolutions per speed, each speed starting from its neighbour's final state on the grown
          casing (the first from rest), same model (built here if `maps` has not run), sense, step
          and casing as the maps; the two
          directions run at once, one rank each. Prints the hysteresis bands (speeds where up and
          down differ by more than 20 %) and where each direction jumps; run/plot_contact_continuation.py
          draws them over the from-rest map. --cont-label names a further range's files and record
          (continuation_<map>_<label>_<up|down>.h5). The linear pair (750:1450:1, 50 revolutions) takes
          about 15 minutes on 2 cores.
  windows  the nonlinear map on fine grids around its interactions (issue 28): `morse sweep` of
          the maps' model (built here if `maps` has not run) with geometric nonlinearity over each
          grid of --windows (lo:hi:step rad/s, from rest, --window-revs revolutions, step
          --map-dt-nonlinear, the maps' sense and casing, -sweep_retries --window-retries if given).
          Prints per speed the LE RMS, max |u_r|,
          the dominant spectral line and its engine order, the largest total normal force, the
          energy at the end and the friction work over the second half; then the window's largest
          RMS and the crossing of its engine order with the free 1B. The two default windows (the
          coarse nonlinear map's 1B/eo8 and 1B/eo6 peaks, 17 speeds each, 20 revolutions, 2.5e-7 s)
          take about 35 minutes each on 2 cores.
  stress  the 1B/eo8 interaction of each sweep (the critical speed nearest 2 pi f_1B / 8 from above,
          within 60 %): a single run at that speed, then `morse stress` at the time of the largest
          radial displacement at LE (Fig. 25).

The casing is the seed's (c0 = 0.356 mm, h_b = 2 c0, 2 lobes, mu = 0.15, 99 % of the distortion at
20 % of the run). The step is 5e-8 s: the linear critical step of r79 is 8.8e-8 s, and the
nonlinear model stiffens under contact (8e-8 s diverges after 0.4 revolutions at 1450 rad/s).
Writes <out>/study.json (what ran, with times) for run/plot_contact_study.py.
"""

import argparse
import concurrent.futures
import json
import math
import os
import shutil
import subprocess
import sys
import threading
import time

import h5py
import numpy as np

from nlrom_study import env  # MPI settings for running as root, one thread per rank

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
MORSE = os.path.join(ROOT, "build", "morse")
DT = 5e-8
OMEGA = 1450.0
CASING = ["-contact_set", "tip", "-contact_mu", "0.15", "-casing_clearance", "3.56e-4", "-casing_lobes", "2"]
ROMS = {"r79": (15, 40), "r89": (20, 45), "r54": (10, 20)}
MAP_ROM = "r79_ms20k"  # the maps' model: r79 mass-scaled to 20 kHz (rom_<MAP_ROM>.h5)
MAP_DT_LINEAR = 8e-6  # the linear maps' step [s]


class Study:
    def __init__(self, out, binary):
        self.out = out
        self.binary = binary
        self.log = open(os.path.join(out, "morse.log"), "a")
        self.path = os.path.join(out, "study.json")
        self.lock = threading.Lock()
        try:
            with open(self.path) as fh:
                self.rec = json.load(fh)
        except (OSError, ValueError):
            self.rec = {}

    def save(self):
        """Merges this run's entries into the record on disk (stages may run as separate processes)."""
        with self.lock:  # runs of one stage may finish at once (threads)
            self._save()

    def _save(self):
        try:
            with open(self.path) as fh:
                disk = json.load(fh)
        except (OSError, ValueError):
            disk = {}
        disk.update(self.rec)
        self.rec = disk
        tmp = "%s.%d.tmp" % (self.path, os.getpid())
        with open(tmp, "w") as fh:
            json.dump(self.rec, fh, indent=1)
        os.replace(tmp, self.path)

    def file(self, name):
        return os.path.join(self.out, name)

    def run(self, nranks, args, label, out_file, key):
        """Runs morse unless out_file exists; records the wall time under rec[key]."""
        if os.path.exists(out_file) and key in self.rec:
            print("  %-44s (done)" % label, flush=True)
            return True
        # --bind-to none: OpenMPI binds a 1-rank job to core 0, so two stages run side by side
        # would share one core.
        cmd = ["mpiexec", "--allow-run-as-root", "--bind-to", "none", "-n", str(nranks), self.binary] + \
            [str(a) for a in args]
        t0 = time.time()
        p = subprocess.run(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, env=env())
        secs = time.time() - t0
        self.log.write("$ %s\n%s\n" % (" ".join(cmd), p.stdout))
        self.log.flush()
        if p.returncode != 0:
            err = [l for l in p.stdout.splitlines() if "morse: error" in l]
            print("  %-44s FAILED: %s" % (label, err[0] if err else p.stdout[-400:]), flush=True)
            self.rec[key] = {"label": label, "seconds": secs, "error": err[0] if err else "exit %d" % p.returncode}
            self.save()
            return False
        print("  %-44s %8.1f s" % (label, secs), flush=True)
        self.rec[key] = {"label": label, "seconds": secs, "file": out_file, "ranks": nranks, "args": cmd[6:]}
        self.save()
        return True


def rom_args(mesh, nfixed, nmd, out):
    return ["nlrom", "-mesh", mesh, "-clamp", "root", "-boundary", "tip", "-nlrom_basis", "cbmd",
            "-nlrom_num_fixed_modes", nfixed, "-nlrom_num_derivatives", nmd, "-nlrom_training_tfinal", 0.0314,
            "-nlrom_damping_modal", "5e-4", "-nlrom_damping_modes", "all", "-nlrom_forces", "exact",
            "-load_sets", "LE", "-load_LE_dir", "y", "-load_LE_amplitude", 300, "-load_LE_omega", 2000, "-out", out]


def simulate(st, rom, omega, revs, dt, linear, name, every):
    out = st.file(name + ".h5")
    args = ["simulate", "-rom", st.file("rom_%s.h5" % rom), "-sim_omega", omega, "-sim_revolutions", revs,
            "-sim_dt", dt, "-sim_output_every", every, "-out", out] + CASING + (["-sim_linear"] if linear else [])
    ok = st.run(1, args, "simulate %s" % name, out, "sim_" + name)
    return out if ok else None


def casing_with_mu(mu):
    """The study's casing options with the friction coefficient mu."""
    casing = list(CASING)
    casing[casing.index("-contact_mu") + 1] = mu
    return casing


def single_scaled_stage(st, args, mesh):
    """Figs. 17-19 with the maps' mass-scaled models (see the module docstring, --single-scaled)."""
    rom, sense = map_model(st, args, mesh)
    if rom is None:
        return
    for name in ("r89", "r54"):
        nf, nmd = ROMS[name]
        path = st.file("rom_%s_ms20k.h5" % name)
        st.run(args.ranks, rom_args(mesh, nf, nmd, path) + ["-nlrom_mass_scaling_fmax", 20000],
               "nlrom %s mass-scaled to 20 kHz" % name, path, "rom_%s_ms20k" % name)
    omega = -OMEGA if sense == "negative" else OMEGA
    dt = args.map_dt_nonlinear
    every = max(1, int(round(1e-6 / dt)))  # about 1 us sampling
    print("Omega = %g rad/s, %g revolutions, mass-scaled models, step %g s" % (omega, args.revs, dt), flush=True)
    runs = [(MAP_ROM, args.revs, dt, False, "fig17_nonlinear", every),
            (MAP_ROM, args.revs, MAP_DT_LINEAR, True, "fig17_linear", 1),
            ("r89_ms20k", args.revs, dt, False, "fig19_r89", every),
            ("r54_ms20k", args.revs, dt, False, "fig19_r54", every),
            (MAP_ROM, 2, dt, False, "fig18_dt", every),
            (MAP_ROM, 2, dt / 5, False, "fig18_dt5", 5 * every)]
    with concurrent.futures.ThreadPoolExecutor(max_workers=max(1, min(2, args.ranks))) as ex:
        list(ex.map(lambda a: simulate(st, a[0], omega, a[1], a[2], a[3], a[4], a[5]), runs))
    st.rec["single_scaled"] = {"omega": omega, "dt": dt, "revs": args.revs, "models": [MAP_ROM, "r89_ms20k",
                                                                                      "r54_ms20k"]}
    st.save()


def diagnosis_stage(st, args, mesh):
    """Why the linear maps were not physical (docs/contact.md): linear sweeps of r54 over
    --diag-revs revolutions with friction (both senses of rotation) and without, the energy
    balance of each speed (/sweep/energy_balance), and single runs at 830 rad/s with the damping on
    10 modes and on every mode."""
    print("diagnosis: linear r54, %g revolutions per speed" % args.diag_revs, flush=True)
    lo, hi, step = parse_range(args.diag_range)
    # The model of the sweeps on this page: r54 with the damping on its first 10 modes (the form
    # before -nlrom_damping_modes all became the study's default), and r54 with every mode damped.
    rom10 = st.file("rom_r54_damp10.h5")
    args10 = rom_args(mesh, 10, 20, rom10)
    args10[args10.index("-nlrom_damping_modes") + 1] = 10
    st.run(args.ranks, args10, "nlrom r54, 10 modes damped", rom10, "rom_r54_damp10")
    base = ["-rom", rom10, "-sweep_omega_min", lo, "-sweep_omega_max", hi, "-sweep_omega_step",
            step, "-sim_revolutions", args.diag_revs, "-sim_dt", DT, "-sweep_batch", 8, "-sim_linear"]
    cases = {"friction": ("0.15", []), "frictionless": ("0", []),
             "friction_negative": ("0.15", ["-sweep_rotation", "negative"])}
    for tag, (mu, extra) in cases.items():
        name = "diag_sweep_" + tag
        path = st.file(name + ".h5")
        st.run(args.ranks, ["sweep", "-out", path] + base + casing_with_mu(mu) + extra, name, path + ".done", name)
        if name in st.rec and "error" not in st.rec[name]:
            open(path + ".done", "w").close()
    rom_all = st.file("rom_r54_alldamped.h5")
    args_all = rom_args(mesh, 10, 20, rom_all)
    args_all[args_all.index("-nlrom_damping_modes") + 1] = "all"
    st.run(args.ranks, args_all, "nlrom r54, every mode damped", rom_all, "rom_r54_alldamped")
    for tag, rom, mu in (("830", "rom_r54_damp10.h5", "0.15"), ("830_frictionless", "rom_r54_damp10.h5", "0"),
                         ("830_alldamped", "rom_r54_alldamped.h5", "0.15")):
        out = st.file("diag_sim_%s.h5" % tag)
        st.run(1, ["simulate", "-rom", st.file(rom), "-sim_omega", 830, "-sim_revolutions", 5, "-sim_dt", DT,
                   "-sim_output_every", 20, "-sim_linear", "-out", out] + casing_with_mu(mu),
               "simulate diag %s" % tag, out, "diag_sim_" + tag)


def rotation_of(rom):
    """The sense of rotation in which the blade's leading edge leads: the chord runs from the LE
    against the rotation (any compressor or turbine rotor), so the sign of Omega is that of
    theta_LE - theta_TE at the tip (theta about z). Returns ("negative"|"positive", derivation text)."""
    with h5py.File(rom, "r") as f:
        ids = f["/mesh/node_ids"][()]
        X = f["/mesh/coordinates"][()]
        th = {}
        for s in ("LE", "TE"):
            nodes = f["/nlrom/node_sets/" + s][()]
            P = X[np.isin(ids, nodes)]
            k = np.argmax(np.hypot(P[:, 0], P[:, 1]))  # the set's node at the tip
            th[s] = (math.atan2(P[k, 1], P[k, 0]), P[k, 2])
    sense = "negative" if th["LE"][0] < th["TE"][0] else "positive"
    text = ("tip LE at theta %.4f rad, z %.4f m; TE at theta %.4f rad, z %.4f m: the leading edge leads for Omega %s"
            % (th["LE"][0], th["LE"][1], th["TE"][0], th["TE"][1], "< 0" if sense == "negative" else "> 0"))
    return sense, text


def map_model(st, args, mesh):
    """The maps' model (r79 mass-scaled to 20 kHz), built if it is not on disk, and the sense of
    rotation (--rotation; auto: the leading edge leads). Returns (rom, sense), or (None, None)."""
    rom = st.file("rom_%s.h5" % MAP_ROM)
    margs = rom_args(mesh, 15, 40, rom) + ["-nlrom_mass_scaling_fmax", 20000]
    if not st.run(args.ranks, margs, "nlrom r79 mass-scaled to 20 kHz", rom, "rom_r79_ms20k"):
        return None, None
    sense, why = (args.rotation, "given") if args.rotation != "auto" else rotation_of(rom)
    print("  rotation: %s (%s)" % (sense, why), flush=True)
    st.rec["map_rotation"] = {"sense": sense, "why": why}
    return rom, sense


def maps_stage(st, args, mesh):
    """The seed-scale maps of the mass-scaled r79 (see the module docstring)."""
    rom, sense = map_model(st, args, mesh)
    if rom is None:
        return
    lo, hi, step = parse_range(args.map_range)
    for tag in args.maps.split(","):
        lin = tag == "linear"
        name = "map_%s_%s" % (tag, sense)
        path = st.file(name + ".h5")
        dt = MAP_DT_LINEAR if lin else args.map_dt_nonlinear
        sargs = ["sweep", "-rom", rom, "-out", path, "-sweep_omega_min", lo, "-sweep_omega_max", hi,
                 "-sweep_omega_step", step, "-sim_revolutions", args.map_revs, "-sim_dt", dt, "-sweep_rotation",
                 sense] + CASING + (["-sim_linear"] if lin else []) + \
            (["-sweep_refine_step", args.map_refine] if args.map_refine > 0 else [])
        st.rec.pop(name, None) if not os.path.exists(path) else None
        st.run(args.ranks, sargs, "%s (r79 mass-scaled, %s rad/s, refined to %s)" % (name, args.map_range,
                                                                                       args.map_refine),
               path + ".done", name)
        if name in st.rec and "error" not in st.rec[name]:
            open(path + ".done", "w").close()


def dominant_lines(spec, freq):
    """The frequency [Hz] of the largest line of each spectrum row (the mean, bin 0, left out). The
    bins hold the largest amplitude over their width (sweeps of 2026-12-02 on), so this is the
    dominant line to within half a bin wherever it falls."""
    return freq[1 + np.argmax(spec[:, 1:], axis=1)]


def dominant_orders(f, sel, w):
    """The dominant engine order of the speeds `sel` of an open sweep file: the largest of the lines
    /sweep/order_amplitude holds at their exact frequencies k |Omega| / 2 pi (an integer), or, in a
    file without them (before 2026-12-02), the largest spectrum bin's frequency in engine orders."""
    if "/sweep/order_amplitude" in f:
        eo = np.nan_to_num(f["/sweep/order_amplitude"][:][sel], nan=-1.0)
        return 1.0 + np.argmax(eo, axis=1)
    return dominant_lines(f["/sweep/spectrum"][:][sel], f["/sweep/frequency"][:]) * 2 * math.pi / w[sel]


def map_interaction(sweep_file, f1b, window, order=8):
    """The main 1B/eo`order` interaction of a map: among the finished speeds in [w0, window w0]
    (w0 = 2 pi f1b / order, the exact crossing), the highest RMS (median over the speeds within
    2 rad/s) of those whose dominant engine order (`dominant_orders`) is `order` (to half an
    order), else the highest in the window; the median runs over the speeds of that choice only.
    Returns a dict
    with the speed (|Omega|), its step, RMS, dominant order and whether the order matched."""
    with h5py.File(sweep_file, "r") as f:
        w = np.abs(f["/sweep/omega"][:])
        rms, status = f["/sweep/rms"][:], f["/sweep/status"][:]
        dt = f["/sweep/dt"][:]
        w0 = 2 * math.pi * f1b / order
        sel = np.flatnonzero((status == 0) & (w >= w0) & (w <= window * w0))
        if sel.size == 0:
            return None
        dom = dominant_orders(f, sel, w)
    match = sel[np.abs(dom - order) <= 0.5]
    pick = match if match.size else sel
    # Neighbouring speeds may land on different branches of coexisting solutions (docs/contact.md,
    # "Coexisting solutions"), and a single run differs from the sweep's by round-off: the speed is
    # chosen by the median RMS of the speeds within 2 rad/s of it (on a map refined to 1 rad/s, it
    # and two neighbours on each side), so that it lies inside a branch rather than on an isolated
    # spike.
    # The median runs over the speeds of the pick (those of the order when some are): a speed of the
    # order among neighbours on another branch (the friction-fed eo6 branch beside eo8 speeds of the
    # low branch, docs/contact.md) is judged by its own branch.
    same = np.zeros(w.size, bool)
    same[pick] = True
    smooth = np.array([np.median(rms[(np.abs(w - x) <= 2.0 + 1e-9) & same]) if same[k] else np.nan
                       for k, x in enumerate(w)])
    i = pick[np.argmax(smooth[pick])]
    return {"omega": float(w[i]), "dt": float(dt[i]), "rms": float(rms[i]), "rms_median": float(smooth[i]),
            "crossing": w0,
            "dominant_order": float(dom[np.flatnonzero(sel == i)[0]]), "order_matched": bool(match.size)}


def map_stress_stage(st, args, mesh):
    """Fig. 25 on the seed-scale maps (see the module docstring)."""
    rom = st.file("rom_%s.h5" % MAP_ROM)
    sense = st.rec.get("map_rotation", {}).get("sense")
    if not os.path.exists(rom) or sense is None:
        print("  map_stress: run the maps stage first", flush=True)
        return
    f1b = first_bending_hz(rom)
    sign = -1.0 if sense == "negative" else 1.0
    for tag in args.maps.split(","):
        lin = tag == "linear"
        sw = st.file("map_%s_%s.h5" % (tag, sense))
        if not os.path.exists(sw + ".done"):
            print("  map_stress: %s is not finished" % sw, flush=True)
            continue
        with h5py.File(sw, "r") as f:
            settings = dict(l.split("=", 1) for l in f["/sweep/settings"][()].decode().splitlines() if "=" in l)
        revs = float(settings["revolutions"])
        it = map_interaction(sw, f1b, args.stress_window)
        if it is None:
            print("  map_stress: no finished speed near 1B/eo8 in %s" % sw, flush=True)
            continue
        print("  %s map: 1B/eo8 interaction at %g rad/s (crossing %.1f; RMS %.3f mm, dominant order %.2f%s)"
              % (tag, it["omega"], it["crossing"], 1e3 * it["rms"], it["dominant_order"],
                 "" if it["order_matched"] else ", no speed on eo8: the highest RMS"), flush=True)
        name = "map_stress_%s" % tag
        st.rec[name + "_interaction"] = it
        # about 40 states per period of the 1B response at 8 Omega
        every = max(1, int(round(2 * math.pi / (8 * it["omega"]) / 40 / it["dt"])))
        sim = simulate(st, MAP_ROM, sign * it["omega"], revs, it["dt"], lin, name + "_sim", every)
        if sim is None:
            continue
        with h5py.File(sim, "r") as f:  # the monitor LE is the first contact node; its u_r over the 2nd half
            t, ur = f["/sim/time"][()], f["/sim/contact/radial_displacement"][()][:, 0]
        it["single_run_rms"] = float(np.sqrt(np.mean(ur[t >= 0.5 * t[-1]] ** 2)))
        print("  single run: LE RMS %.3f mm over the second half (sampled every %d steps), the map's %.3f mm"
              % (1e3 * it["single_run_rms"], every, 1e3 * it["rms"]), flush=True)
        if st.run(args.ranks, ["stress", "-rom", rom, "-sim", sim, "-mesh", mesh, "-out", st.file(name + ".h5")],
                  "stress %s" % name, st.file(name + ".h5"), name):
            it["by_distance"] = stress_by_contact_distance(st.file(name + ".h5"), rom)
            for b in it["by_distance"]:
                print("    %4.0f-%4.0f mm from a contact node: %5d elements, von Mises median %8.0f MPa, "
                      "90 %% %8.0f, max %10.0f at %.0f %% span" % (b["from_mm"], b["to_mm"], b["elements"],
                                                                  b["median_mpa"], b["p90_mpa"], b["max_mpa"],
                                                                  100 * b["span_of_max"]), flush=True)
    st.save()


def stress_by_contact_distance(stress_file, rom, edges_mm=(0, 8, 15, 30, 1e6)):
    """Element von Mises of a `morse stress` file binned by the distance of the element's centroid
    from the nearest contact node (the point loads of the casing), with the span (0 root, 1 tip, by
    radius) of each bin's maximum."""
    with h5py.File(stress_file, "r") as f:
        X, ids = f["/mesh/coordinates"][()], f["/mesh/node_ids"][()]
        vm = f["/stress/von_mises_element"][0]
        top = f["/mesh/topology"][()].reshape(vm.size, -1)
    with h5py.File(rom, "r") as f:
        tip = f["/nlrom/node_sets/tip"][()]
    pos = {n: i for i, n in enumerate(ids)}
    T = X[[pos[n] for n in tip]]
    rad = np.hypot(X[:, 0], X[:, 1])
    C = X[top].mean(1)
    dist = 1e3 * np.min(np.linalg.norm(C[:, None, :] - T[None], axis=2), 1)
    span = (np.hypot(C[:, 0], C[:, 1]) - rad.min()) / (rad.max() - rad.min())
    out = []
    for lo, hi in zip(edges_mm[:-1], edges_mm[1:]):
        s = (dist >= lo) & (dist < hi)
        if not s.any():
            continue
        k = int(np.argmax(np.where(s, vm, -1.0)))
        out.append({"from_mm": lo, "to_mm": min(hi, float(dist.max())), "elements": int(s.sum()),
                    "median_mpa": float(np.median(vm[s]) / 1e6), "p90_mpa": float(np.percentile(vm[s], 90) / 1e6),
                    "max_mpa": float(vm[k] / 1e6), "span_of_max": float(span[k]),
                    "above_2000_mpa": int((vm[s] > 2e9).sum())})
    return out


def realizations_stage(st, args, mesh):
    """The linear map's coarse grid again with the speeds perturbed by round-off (see the docstring)."""
    rom = st.file("rom_%s.h5" % MAP_ROM)
    sense = st.rec.get("map_rotation", {}).get("sense")
    ref = st.file("map_linear_%s.h5" % sense) if sense else None
    if ref is None or not os.path.exists(ref + ".done"):
        print("  realizations: run the linear map first (--stages maps --maps linear)", flush=True)
        return
    lo, hi, step = parse_range(args.map_range)
    files = {"0": ref}
    for e in args.realizations.split(","):
        f = 1.0 + float(e)
        path = st.file("map_linear_%s_realization_%s.h5" % (sense, e))
        sargs = ["sweep", "-rom", rom, "-out", path, "-sweep_omega_min", repr(lo * f), "-sweep_omega_max", repr(hi * f),
                 "-sweep_omega_step", repr(step * f), "-sim_revolutions", args.map_revs, "-sim_dt", MAP_DT_LINEAR,
                 "-sweep_rotation", sense, "-sim_linear"] + CASING
        if st.run(args.ranks, sargs, "linear map, speeds x (1 + %s)" % e, path + ".done", "realization_" + e):
            open(path + ".done", "w").close()
            files[e] = path
    grid, rows = None, []
    for e, path in files.items():
        with h5py.File(path, "r") as f:
            w, rms = np.abs(f["/sweep/omega"][:]), f["/sweep/rms"][:]
        if grid is None:
            grid = np.array([lo + k * step for k in range(int(round((hi - lo) / step)) + 1)])
        rows.append([rms[np.argmin(np.abs(w - x))] for x in grid])  # nearest speed: the perturbed one
    R = np.array(rows)
    spread = R.max(0) / R.min(0)
    wide = [float(x) for x in grid[spread > 1.2]]
    print("  %d realizations of %d speeds: RMS spread (largest / smallest) median %.3f, 90 %% %.3f, largest %.2f "
          "at %g rad/s; above 1.2 at %s" % (len(rows), grid.size, np.median(spread), np.percentile(spread, 90),
                                            spread.max(), grid[np.argmax(spread)], wide), flush=True)
    st.rec["realizations"] = {"files": files, "speeds": grid.tolist(), "rms": R.tolist(),
                              "spread_median": float(np.median(spread)), "spread_max": float(spread.max()),
                              "speeds_spread_above_1.2": wide}
    st.save()


def windows_stage(st, args, mesh):
    """The nonlinear map on fine grids around its interactions (see the module docstring)."""
    rom, sense = map_model(st, args, mesh)
    if rom is None:
        return
    f1b = first_bending_hz(rom)  # the 1B of the model without contact
    for rng in args.windows.split(","):
        lo, hi, step = parse_range(rng)
        name = "window_nonlinear_%s_%g_%g" % (sense, lo, hi)
        path = st.file(name + ".h5")
        sargs = ["sweep", "-rom", rom, "-out", path, "-sweep_omega_min", lo, "-sweep_omega_max", hi,
                 "-sweep_omega_step", step, "-sim_revolutions", args.window_revs, "-sim_dt", args.map_dt_nonlinear,
                 "-sweep_rotation", sense] + CASING + \
            ([] if args.window_retries is None else ["-sweep_retries", args.window_retries]) + \
            ([] if args.window_refine <= 0 else ["-sweep_refine_step", args.window_refine] +
             (["-sweep_refine_orders", args.window_refine_orders] if args.window_refine_orders else []))
        st.rec.pop(name, None) if not os.path.exists(path) else None
        st.run(args.ranks, sargs, "%s (%s rad/s, %g revolutions)" % (name, rng, args.window_revs), path + ".done",
               name)
        if name not in st.rec or "error" in st.rec[name]:
            continue
        open(path + ".done", "w").close()
        with h5py.File(path, "r") as f:
            w = np.abs(f["/sweep/omega"][:])
            o = np.argsort(w)
            w = w[o]
            rms, status = f["/sweep/rms"][:][o], f["/sweep/status"][:][o]
            umax, fmax = f["/sweep/max_displacement"][:][o], f["/sweep/max_contact_force"][:][o]
            spec, freq = f["/sweep/spectrum"][:][o], f["/sweep/frequency"][:]
            dt = f["/sweep/dt"][:][o]
            eb = f["/sweep/energy_balance"][:][o]
            eo = f["/sweep/order_amplitude"][:][o] if "/sweep/order_amplitude" in f else None
        rows = []
        shown = [int(x) for x in args.window_lines.split(",") if x] if eo is not None else []
        print("  %s: |Omega| [rad/s], LE RMS [mm], max |u_r| [mm], dominant line [Hz], its engine order, "
              "max total force [kN], energy at the end [J], friction work over the 2nd half [J], step [s]" % name, flush=True)
        lines = dominant_lines(spec, freq)
        for k in range(w.size):
            line = float(lines[k]) if status[k] == 0 else float("nan")
            row = {"omega": float(w[k]), "status": int(status[k]), "rms_mm": 1e3 * float(rms[k]),
                   "max_mm": 1e3 * float(umax[k]), "line_hz": line, "order": line * 2 * math.pi / w[k],
                   "force_kn": 1e-3 * float(fmax[k]), "energy_end": float(eb[k, 5]),
                   "friction_2nd_half": float(eb[k, 8] - eb[k, 3]), "dt": float(dt[k])}
            for n in shown:  # engine-order lines at their exact frequencies (/sweep/order_amplitude)
                if n <= eo.shape[1]:
                    row["eo%d_mm" % n] = 1e3 * float(eo[k, n - 1])
            rows.append(row)
            print("    %7.1f  %6.3f  %6.2f  %7.1f  %5.2f  %8.1f  %7.1f  %8.1f  %.3g%s%s" %
                  (row["omega"], row["rms_mm"], row["max_mm"], line, row["order"], row["force_kn"],
                   row["energy_end"], row["friction_2nd_half"], row["dt"],
                   "".join("  eo%d %.3f mm" % (n, row["eo%d_mm" % n]) for n in shown if "eo%d_mm" % n in row),
                   "" if status[k] == 0 else "  FAILED"),
                  flush=True)
        ok = [r for r in rows if r["status"] == 0]
        peak = max(ok, key=lambda r: r["rms_mm"]) if ok else None
        rec = {"range": rng, "revs": args.window_revs, "f1b_hz": f1b, "rows": rows, "peak": peak}
        if peak is not None:
            n = round(peak["order"])
            rec["peak_order"] = n
            rec["crossing_free_1b"] = 2 * math.pi * f1b / n
            print("  %s: the largest RMS %.3f mm at %g rad/s, line %.0f Hz = engine order %.2f (the free 1B's "
                  "eo%d crossing: %.0f rad/s)" % (name, peak["rms_mm"], peak["omega"], peak["line_hz"],
                                                  peak["order"], n, rec["crossing_free_1b"]), flush=True)
        st.rec[name + "_analysis"] = rec
        st.save()


def continuation_stage(st, args, mesh):
    """Both branches by continuation up and down (see the module docstring)."""
    rom, sense = map_model(st, args, mesh)
    if rom is None:
        return
    lo, hi, step = parse_range(args.cont_range)
    label = "_" + args.cont_label if args.cont_label else ""
    for tag in args.cont_maps.split(","):
        lin = tag == "linear"
        dt = MAP_DT_LINEAR if lin else args.map_dt_nonlinear
        files = {}

        def one(direction):
            name = "continuation_%s%s_%s" % (tag, label, direction)
            path = st.file(name + ".h5")
            sargs = ["sweep", "-rom", rom, "-out", path, "-sweep_omega_min", lo, "-sweep_omega_max", hi,
                     "-sweep_omega_step", step, "-sim_revolutions", args.cont_revs, "-sim_dt", dt, "-sweep_rotation",
                     sense, "-sweep_continuation", direction, "-sweep_chains", 1, "-sweep_retries", 0] + CASING + \
                (["-sim_linear"] if lin else [])
            if st.run(1, sargs, "%s (%s rad/s, %g revolutions)" % (name, args.cont_range, args.cont_revs),
                      path + ".done", name):
                open(path + ".done", "w").close()
                files[direction] = path

        with concurrent.futures.ThreadPoolExecutor(max_workers=max(1, min(2, args.ranks))) as ex:
            list(ex.map(one, ["up", "down"]))
        if len(files) < 2:
            continue
        res, tangent = {}, {}
        for direction, path in files.items():
            with h5py.File(path, "r") as f:
                w, rms = np.abs(f["/sweep/omega"][:]), f["/sweep/rms"][:]
                frm = f["/sweep/continuation"][:, 0]
                if "/sweep/tangent" in f:  # the smallest tangent critical step of each speed (-sim_tangent_checks)
                    hT = f["/sweep/tangent"][:, 0]
                    tangent[direction] = {"min": float(hT.min()), "max": float(hT.max()),
                                          "dt_over_min": float(f["/sweep/dt"][:].max() / hT.min())}
            o = np.argsort(w)
            res[direction] = (w[o], rms[o], frm[o])
        w, up, down = res["up"][0], res["up"][1], res["down"][1]
        ratio = np.maximum(up, down) / np.minimum(up, down)
        bands, k = [], 0
        while k < w.size:  # runs of neighbouring speeds where the branches differ
            if ratio[k] > 1.2:
                j = k
                while j + 1 < w.size and ratio[j + 1] > 1.2:
                    j += 1
                bands.append([float(w[k]), float(w[j]), "up" if up[k:j + 1].mean() > down[k:j + 1].mean()
                              else "down"])
                k = j + 1
            else:
                k += 1

        def jumps(r):  # neighbouring speeds whose RMS differ by more than 1.5 x
            q = r[1:] / r[:-1]
            return [[float(w[i]), float(w[i + 1]), float(q[i])] for i in np.nonzero((q > 1.5) | (q < 1 / 1.5))[0]]

        rec = {"files": files, "range": args.cont_range, "revs": args.cont_revs, "bands": bands,
               "jumps_up": jumps(up), "jumps_down": jumps(down), "rms_max_up": float(up.max()),
               "rms_max_down": float(down.max()), "speeds_differing": int((ratio > 1.2).sum()),
               "speeds": int(w.size), "tangent_dt_min": tangent}
        for direction, tg in tangent.items():
            print("  %s %s: smallest tangent critical step over the speeds %.3g-%.3g s (dt / smallest up to %.2f)"
                  % (tag, direction, tg["min"], tg["max"], tg["dt_over_min"]), flush=True)
        print("  %s: %d of %d speeds differ by > 20 %% between up and down; bands %s" %
              (tag, rec["speeds_differing"], w.size, ["%g-%g (%s higher)" % tuple(b) for b in bands]), flush=True)
        print("  %s: jumps up %s; down %s" % (tag, ["%g->%g x%.2f" % tuple(j) for j in rec["jumps_up"]],
                                              ["%g->%g x%.2f" % tuple(j) for j in rec["jumps_down"]]), flush=True)
        st.rec["continuation_" + tag + label] = rec
        st.save()


def parse_range(s):
    lo, hi, step = (float(x) for x in s.split(":"))
    return lo, hi, step


def first_bending_hz(rom):
    with h5py.File(rom, "r") as f:
        K, M = f["/nlrom/K"][:], f["/nlrom/M"][:]
    w2 = np.sort(np.linalg.eigvals(np.linalg.solve(M, K)).real)
    return math.sqrt(w2[0]) / (2 * math.pi)


def critical_1b_eo8(sweep_file, f1b):
    """The speed of the highest RMS at or above the exact 1B/eo8 crossing, within 60 % of it."""
    with h5py.File(sweep_file, "r") as f:
        w, rms, status = f["/sweep/omega"][:], f["/sweep/rms"][:], f["/sweep/status"][:]
    w0 = 2 * math.pi * f1b / 8.0
    sel = (status == 0) & (w >= w0) & (w <= 1.6 * w0)
    if not sel.any():
        return None
    i = np.flatnonzero(sel)[np.argmax(rms[sel])]
    return float(w[i])


def critical_step(rom):
    """2 / omega_max of the reduced (K, M): the central-difference limit of the linear model."""
    with h5py.File(rom, "r") as f:
        K, M = f["/nlrom/K"][:], f["/nlrom/M"][:]
    return 2.0 / math.sqrt(np.max(np.linalg.eigvals(np.linalg.solve(M, K)).real))


def le_radial(rom, sim):
    """The LE node id (first contact node of a simulate file) and its e_r = (x, y, 0)/|(x, y)|."""
    with h5py.File(sim, "r") as f:
        le = int(f["/sim/contact/node_ids"][0])
    with h5py.File(rom, "r") as f:
        i = int(np.flatnonzero(f["/mesh/node_ids"][()] == le)[0])
        x = f["/mesh/coordinates"][i]
    rho = math.hypot(x[0], x[1])
    return le, (x[0] / rho, x[1] / rho, 0.0)


def pod_stage(st, args, mesh, every):
    """Seed 003 Figs. 20-22: POD bases trained on full-order runs driven by (a) a harmonic radial load
    at LE and (b) the contact forces of the MD model (r79) over its first --pod-train-revs revolutions,
    then the contact simulation of each POD ROM at 1450 rad/s against the MD model's, all over --pod-revs
    revolutions (the casing's growth rate depends on the run length, so every run has the same one)."""
    revs, train = args.pod_revs, args.pod_train_revs
    T_train = train * 2 * math.pi / OMEGA
    print("POD bases trained on the full model (Figs. 20-22): %g revolutions, training %g" % (revs, train),
          flush=True)
    rom79 = st.file("rom_r79.h5")
    if not st.run(args.ranks, rom_args(mesh, *ROMS["r79"], rom79), "nlrom r79 (24 + 15 + 40)", rom79, "rom_r79"):
        return
    md_name = "fig17_nonlinear" if revs == args.revs else "pod_md_%grev" % revs
    md = simulate(st, "r79", OMEGA, revs, DT, False, md_name, every)
    if md is None:
        return
    st.rec["pod_md"] = md_name
    le, er = le_radial(rom79, md)
    fom_common = ["fom", "-mesh", mesh, "-clamp", "root", "-fom_dt", args.pod_fom_dt, "-fom_tfinal", T_train,
                  "-fom_snapshot_every", args.pod_snap_every, "-fom_monitor", "LE", "-fom_damping_modal", "5e-4",
                  "-fom_damping_modes", 10]
    trainings = {
        # (a) the seed's training of §4 (300 N at LE, 2000 rad/s) turned radial, as the seed does in §5
        "harmonic": ["-load_sets", "LE", "-load_LE_dir", "%.9g,%.9g,%.9g" % er, "-load_LE_amplitude",
                     args.pod_harmonic_amplitude, "-load_LE_omega", args.pod_harmonic_omega],
        # (b) the MD model's contact forces (interval means of /sim/contact/mean_force)
        "contact": ["-load_history", md],
        # (b') the same forces on the linear twin of the full model (a diagnosis: docs/contact.md)
        "contact_linear": ["-load_history", md, "-fom_linear"],
    }
    for tag in args.pod_trainings.split(","):
        fom = st.file("pod_fom_%s.h5" % tag)
        if not st.run(args.ranks, fom_common + trainings[tag] + ["-out", fom], "fom training (%s)" % tag, fom,
                      "pod_fom_" + tag):
            continue
        rom = st.file("rom_pod_%s.h5" % tag)
        nargs = ["nlrom", "-mesh", mesh, "-clamp", "root", "-boundary", "tip", "-nlrom_basis", "pod", "-nlrom_num_pod",
                 args.pod_num, "-nlrom_snapshots", fom, "-nlrom_forces", "exact", "-nlrom_damping_modal", "5e-4",
                 "-nlrom_damping_modes", "all", "-out", rom]
        if not st.run(args.ranks, nargs, "nlrom pod %s (24 + %d)" % (tag, args.pod_num), rom, "rom_pod_" + tag):
            continue
        hc = critical_step(rom)
        dt = DT if DT < 0.9 * hc else 0.9 * hc
        st.rec["pod_critical_dt_" + tag] = hc
        simulate(st, "pod_%s" % tag, OMEGA, revs, dt, False, "pod_sim_%s" % tag, max(1, int(round(every * DT / dt))))
    st.rec["pod_le"] = le
    st.save()


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--mesh", default=os.path.join(ROOT, "meshes", "blade_coarse.msh"))
    ap.add_argument("--out", default=os.path.join(ROOT, "out", "contact_study"))
    ap.add_argument("--stages", default="roms,single,pod,sweep,stress")
    ap.add_argument("--ranks", type=int, default=2)
    ap.add_argument("--revs", type=float, default=10.0)
    ap.add_argument("--single-scaled", action="store_true",
                    help="single: the maps' mass-scaled models, sense and steps (the 60k blade)")
    ap.add_argument("--sweep-revs", type=float, default=5.0)
    ap.add_argument("--sweeps", default="linear,nonlinear", help="which sweeps (and stress cases) to run")
    ap.add_argument("--sweep-linear", default="750:2200:10")
    ap.add_argument("--sweep-nonlinear", default="750:2200:50")
    ap.add_argument("--pod-revs", type=float, default=5.0, help="pod: revolutions of the compared contact runs")
    ap.add_argument("--pod-train-revs", type=float, default=1.0, help="pod: length of the full-order training runs")
    ap.add_argument("--pod-fom-dt", type=float, default=1e-6, help="pod: step of the full-order training runs [s]")
    ap.add_argument("--pod-snap-every", type=int, default=5, help="pod: snapshot every K full-order steps")
    ap.add_argument("--pod-num", type=int, default=20, help="pod: POD vectors (the seed: 20, with 24 constraint modes)")
    ap.add_argument("--pod-harmonic-amplitude", type=float, default=300.0, help="pod (a): force at LE [N]")
    ap.add_argument("--pod-harmonic-omega", type=float, default=2000.0, help="pod (a): [rad/s]")
    ap.add_argument("--pod-trainings", default="contact,harmonic,contact_linear",
                    help="pod: which trainings (contact, harmonic, contact_linear)")
    ap.add_argument("--diag-revs", type=float, default=20.0, help="diagnosis: revolutions per speed")
    ap.add_argument("--diag-range", default="750:2150:100", help="diagnosis: speed grid min:max:step [rad/s]")
    ap.add_argument("--maps", default="linear", help="maps: linear and/or nonlinear")
    ap.add_argument("--map-range", default="750:2190:16", help="maps: coarse grid min:max:step [rad/s]")
    ap.add_argument("--map-refine", type=float, default=1.0, help="maps: finest step [rad/s]; 0: no refinement")
    ap.add_argument("--map-revs", type=float, default=200.0, help="maps: revolutions per speed")
    ap.add_argument("--map-dt-nonlinear", type=float, default=5e-7, help="maps: step of the nonlinear map [s]")
    ap.add_argument("--rotation", default="auto", choices=["auto", "positive", "negative"])
    ap.add_argument("--realizations", default="1e-12,-1e-12",
                    help="realizations: relative speed perturbations of the extra linear maps")
    ap.add_argument("--stress-window", type=float, default=2.0,
                    help="map_stress: the 1B/eo8 interaction is sought up to this multiple of its crossing")
    ap.add_argument("--windows", default="1280:1440:10,1680:1840:10",
                    help="windows: fine grids lo:hi:step of the nonlinear map, comma separated")
    ap.add_argument("--window-revs", type=float, default=20.0, help="windows: revolutions per speed")
    ap.add_argument("--window-retries", type=int, default=None,
                    help="windows: -sweep_retries (default: morse's, 1; a retry at half the step costs twice the speed)")
    ap.add_argument("--window-refine", type=float, default=0.0,
                    help="windows: -sweep_refine_step (0: none; the window's step must be 2^k times it)")
    ap.add_argument("--window-refine-orders", default="",
                    help="windows: -sweep_refine_orders, e.g. 6 (refine on these engine-order lines)")
    ap.add_argument("--window-lines", default="2,6,8",
                    help="windows: engine orders whose line amplitudes are printed and recorded")
    ap.add_argument("--cont-maps", default="linear", help="continuation: linear and/or nonlinear")
    ap.add_argument("--cont-range", default="750:1450:1", help="continuation: lo:hi:step rad/s")
    ap.add_argument("--cont-revs", type=float, default=50.0, help="continuation: revolutions per speed")
    ap.add_argument("--cont-label", default="", help="continuation: a name for this range (files "
                    "continuation_<map>_<label>_<up|down>.h5, record continuation_<map>_<label>)")
    ap.add_argument("--binary", default=None, help="a morse binary (default: a private copy of build/morse)")
    ap.add_argument("--sliding", default="relative", choices=["relative", "rotation"],
                    help="the friction law of every contact run (-contact_sliding): relative (the Coulomb law on "
                    "the tip's velocity relative to the casing, the default) or rotation (the seed's: along "
                    "sign(Omega) e_theta). A study directory holds one law")
    args = ap.parse_args()
    out = os.path.abspath(args.out)
    os.makedirs(out, exist_ok=True)
    binary = args.binary
    if binary is None:  # a rebuild during the study must not pull the binary away
        binary = os.path.join(out, "morse")
        shutil.copy2(MORSE, binary + ".tmp")
        os.replace(binary + ".tmp", binary)
    st = Study(out, binary)
    # Results of the other law must not be taken as done: a record from before --sliding was made
    # with the rotation law.
    held = st.rec.get("contact_sliding", "rotation" if st.rec else args.sliding)
    if held != args.sliding:
        sys.exit("contact_study: %s holds results of the %s friction law (--sliding %s); give --sliding %s or "
                 "another --out" % (out, held, held, held))
    st.rec["contact_sliding"] = args.sliding
    CASING.extend(["-contact_sliding", args.sliding])
    st.rec.update({"mesh": os.path.abspath(args.mesh), "dt": DT, "omega_single": OMEGA, "revs": args.revs,
                   "sweep_revs": args.sweep_revs, "casing": CASING})
    stages = args.stages.split(",")
    mesh = os.path.abspath(args.mesh)

    if "roms" in stages:
        print("reduced models", flush=True)
        for name, (nf, nmd) in ROMS.items():
            path = st.file("rom_%s.h5" % name)
            st.run(args.ranks, rom_args(mesh, nf, nmd, path), "nlrom %s (24 + %d + %d)" % (name, nf, nmd), path,
                   "rom_" + name)
        st.rec["f1b_hz"] = first_bending_hz(st.file("rom_r79.h5"))
        st.save()

    every = 20  # 1 us sampling at 5e-8 s: 14 samples per period of the 6th mode
    if "single" in stages and args.single_scaled:
        single_scaled_stage(st, args, mesh)
    elif "single" in stages:
        print("Omega = %g rad/s, %g revolutions" % (OMEGA, args.revs), flush=True)
        simulate(st, "r79", OMEGA, args.revs, DT, False, "fig17_nonlinear", every)
        simulate(st, "r79", OMEGA, args.revs, DT, True, "fig17_linear", every)
        simulate(st, "r89", OMEGA, args.revs, DT, False, "fig19_r89", every)
        simulate(st, "r54", OMEGA, args.revs, DT, False, "fig19_r54", every)
        simulate(st, "r79", OMEGA, 2, DT, False, "fig18_dt", every)
        simulate(st, "r79", OMEGA, 2, DT / 5, False, "fig18_dt5", 5 * every)

    if "pod" in stages:
        pod_stage(st, args, mesh, every)

    if "sweep" in stages:
        todo = {"linear": (True, args.sweep_linear), "nonlinear": (False, args.sweep_nonlinear)}
        for tag in args.sweeps.split(","):
            lin, rng = todo[tag]
            rom = "r54"
            lo, hi, step = parse_range(rng)
            name = "sweep_%s" % ("linear" if lin else "nonlinear")
            path = st.file(name + ".h5")
            sargs = ["sweep", "-rom", st.file("rom_%s.h5" % rom), "-out", path, "-sweep_omega_min", lo,
                     "-sweep_omega_max", hi, "-sweep_omega_step", step, "-sim_revolutions", args.sweep_revs,
                     "-sim_dt", DT, "-sweep_batch", 8] + CASING + (["-sim_linear"] if lin else [])
            # -sweep_batch 8: a lane's bits do not depend on its batch (theory §10.4), so this only
            # makes the batched potential kernel pay. A resumed sweep continues the file; the
            # record is only rewritten when it ends.
            st.rec.pop(name, None) if not os.path.exists(path) else None
            st.run(args.ranks, sargs, "%s (%s, %s rad/s)" % (name, rom, rng), path + ".done", name)
            if name in st.rec and "error" not in st.rec[name]:
                open(path + ".done", "w").close()

    if "diagnosis" in stages:
        diagnosis_stage(st, args, mesh)

    if "maps" in stages:
        maps_stage(st, args, mesh)

    if "realizations" in stages:
        realizations_stage(st, args, mesh)

    if "windows" in stages:
        print("the nonlinear map on fine grids around its interactions", flush=True)
        windows_stage(st, args, mesh)

    if "continuation" in stages:
        print("continuation up and down (both branches)", flush=True)
        continuation_stage(st, args, mesh)
    if "map_stress" in stages:
        map_stress_stage(st, args, mesh)

    if "stress" in stages:
        f1b = st.rec.get("f1b_hz") or first_bending_hz(st.file("rom_r79.h5"))
        for tag in args.sweeps.split(","):
            lin, rom = tag == "linear", "r54"
            sw = st.file("sweep_%s.h5" % tag)
            if not os.path.exists(sw):
                continue
            w = critical_1b_eo8(sw, f1b)
            if w is None:
                print("  no 1B/eo8 interaction found in %s" % sw, flush=True)
                continue
            st.rec["critical_1b_eo8_" + tag] = w
            name = "stress_%s" % tag
            sim = simulate(st, rom, w, args.sweep_revs, DT, lin, name + "_sim", every)
            if sim is None:
                continue
            st.run(1, ["stress", "-rom", st.file("rom_%s.h5" % rom), "-sim", sim, "-mesh", mesh, "-out",
                       st.file(name + ".h5")], "stress %s at %g rad/s" % (tag, w), st.file(name + ".h5"), name)
    st.save()


if __name__ == "__main__":
    sys.exit(main())
