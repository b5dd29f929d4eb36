"""Shared helpers of the morse benchmarks (standard library only, Debian's /usr/bin/python3).

Running morse under mpirun with per-rank /usr/bin/time, parsing morse's stage table and
-log_view, measuring the load other processes put on the machine, medians, and the provenance
(BLAS libraries, git commit) recorded in every results JSON.
"""

import os
import re
import shutil
import statistics
import subprocess
import sys
import time

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
RESULTS = os.path.join(HERE, "results")

EXTRA_ENV = {}


def mpi_env(omp_threads):
    env = dict(os.environ)
    env.update(EXTRA_ENV)
    env.update({"OMPI_ALLOW_RUN_AS_ROOT": "1", "OMPI_ALLOW_RUN_AS_ROOT_CONFIRM": "1",
                "OMPI_MCA_rmaps_base_oversubscribe": "1",
                "OMPI_MCA_btl_vader_single_copy_mechanism": "none",
                "OMP_NUM_THREADS": str(omp_threads), "OPENBLAS_NUM_THREADS": str(omp_threads)})
    return env


def parse_log_view(text, events):
    """Max time over ranks [s] and call count of the -log_view events in `events` and morse's own."""
    out = {}
    for line in text.splitlines():
        f = line.split()
        if len(f) > 4 and (f[0] in events or f[0].startswith("morse:")):
            try:
                out[f[0]] = {"count": int(f[1]), "seconds": float(f[3])}
            except ValueError:
                pass
    return out


def parse_stage_table(stdout):
    """morse's stage table ("stage  time [s]  peak [MB]") as (seconds, peak_mb) dicts; a stage that
    appears several times is summed (time) / maxed (peak). The key "total" is "total (wall)"."""
    sec, peak = {}, {}
    for line in stdout.splitlines():
        m = re.match(r"^\s+(\w+|total \(wall\))\s+([0-9.]+)\s+([0-9.]+)\s*$", line)
        if not m:
            continue
        key = "total" if m.group(1).startswith("total") else m.group(1)
        sec[key] = sec.get(key, 0.0) + float(m.group(2))
        peak[key] = max(peak.get(key, 0.0), float(m.group(3)))
    return sec, peak


def proc_stat():
    """(busy, total) CPU seconds of the whole machine so far, from /proc/stat."""
    try:
        with open("/proc/stat") as f:
            v = [int(x) for x in f.readline().split()[1:]]
    except OSError:
        return None
    hz = os.sysconf("SC_CLK_TCK")
    return (sum(v) - v[3] - v[4]) / hz, sum(v) / hz


def cpu_busy(seconds=1.0):
    """Fraction of all CPUs busy (any process) over `seconds`, from /proc/stat."""
    def snap():
        with open("/proc/stat") as f:
            v = [int(x) for x in f.readline().split()[1:]]
        return sum(v), v[3] + v[4]  # total, idle + iowait
    try:
        t0, i0 = snap()
        time.sleep(seconds)
        t1, i1 = snap()
    except OSError:
        return None
    return 1.0 - (i1 - i0) / max(1, t1 - t0)


def wait_idle(limit, timeout):
    """Waits until the machine is (nearly) idle; returns the last busy fraction measured."""
    t0 = time.monotonic()
    busy = cpu_busy()
    warned = False
    while busy is not None and busy > limit and time.monotonic() - t0 < timeout:
        if not warned:
            print("  waiting for an idle machine (%.0f%% of the CPUs busy)..." % (100 * busy), flush=True)
            warned = True
        busy = cpu_busy(2.0)
    return busy


def run_mpi(name, morse_args, ranks, work_dir, omp_threads, launcher=None, failure=None):
    """Runs `mpirun -n ranks [/usr/bin/time] morse_args...` (`launcher(ranks)` instead of
    `mpirun -n ranks` if given). Returns (result, cmd) where result is None on failure, else a
    dict: stdout, stderr, process_wall, rank_max_rss_mb, sum_max_rss_mb, rank_cpu_seconds,
    foreign_cpu_fraction (CPU other processes used, as a fraction of all CPUs over the run) and
    contention (cores' worth of that foreign work beyond the cores morse left idle, per rank).
    With a list `failure`, the failure's text is appended to it instead of printed."""
    cmd = launcher(ranks) if launcher else ["mpirun", "-n", str(ranks)]
    # Each rank's /usr/bin/time appends one line to its own file (on a shared stderr the lines of
    # the ranks can interleave and be lost).
    time_file = os.path.join(work_dir, "time.txt")
    if os.path.exists(time_file):
        os.remove(time_file)
    if os.path.exists("/usr/bin/time"):
        cmd += ["/usr/bin/time", "-a", "-o", time_file, "-f", "BENCH_MAXRSS_KB %M BENCH_CPU_S %U %S"]
    cmd += morse_args
    st0 = proc_stat()
    t0 = time.monotonic()
    p = subprocess.run(cmd, capture_output=True, text=True, env=mpi_env(omp_threads))
    wall = time.monotonic() - t0
    st1 = proc_stat()
    if p.returncode != 0:
        text = "exit %d\n--- stdout\n%s\n--- stderr\n%s" % (p.returncode, p.stdout[-4000:], p.stderr[-4000:])
        if failure is not None:
            failure.append(text)
        else:
            sys.stderr.write("%s: FAILED (%s): %s\n" % (name, " ".join(cmd), text))
        return None, cmd
    timing = ""
    if os.path.exists(time_file):
        with open(time_file) as f:
            timing = f.read()
    r = {"stdout": p.stdout, "stderr": p.stderr, "ranks": ranks, "process_wall": wall}
    rss = [int(x) for x in re.findall(r"^BENCH_MAXRSS_KB (\d+)", timing, re.M)]
    r["rank_max_rss_mb"] = [k / 1024.0 for k in rss]
    r["sum_max_rss_mb"] = sum(rss) / 1024.0 if rss else None
    r["rank_cpu_seconds"] = [float(u) + float(s) for u, s in re.findall(r"BENCH_CPU_S ([0-9.]+) ([0-9.]+)", timing)]
    if len(r["rank_cpu_seconds"]) != ranks:
        sys.stderr.write("%s: /usr/bin/time reported %d of %d ranks; no load or all-rank memory figure for "
                         "this run\n" % (name, len(r["rank_cpu_seconds"]), ranks))
        r["sum_max_rss_mb"] = None
    if st0 and st1 and len(r["rank_cpu_seconds"]) == ranks:
        busy = st1[0] - st0[0]
        ncpu = os.cpu_count() or 1
        r["foreign_cpu_fraction"] = max(0.0, busy - sum(r["rank_cpu_seconds"])) / (wall * ncpu)
        r["contention"] = max(0.0, r["foreign_cpu_fraction"] * ncpu - max(0, ncpu - ranks)) / ranks
    else:
        r["foreign_cpu_fraction"] = r["contention"] = None
    return r, cmd


def med(xs):
    xs = [x for x in xs if x is not None]
    return statistics.median(xs) if xs else None


def blas_info(morse):
    """The BLAS/LAPACK libraries morse loads (ldd, with the benchmark's environment)."""
    try:
        p = subprocess.run(["ldd", morse], capture_output=True, text=True, env=mpi_env(1))
    except OSError:
        return None
    libs = {}
    for line in p.stdout.splitlines():
        f = line.split()
        if f and re.match(r"lib(blas|lapack|openblas|blis|mkl)", f[0]):
            target = f[2] if len(f) > 2 else f[0]
            libs[f[0]] = os.path.realpath(target) if os.path.exists(target) else target
    return libs


def git_info():
    def g(*a):
        try:
            return subprocess.run(["git", "-C", ROOT] + list(a), capture_output=True, text=True).stdout.strip()
        except OSError:
            return None
    return {"commit": g("rev-parse", "HEAD"), "dirty_files": g("status", "--porcelain").splitlines()}


def fmt(x, w=9, p=3):
    return ("%*.*f" % (w, p, x)) if x is not None else " " * (w - 1) + "-"


def ensure_ccx(install=True):
    """CalculiX (Debian's calculix-ccx): its executable, installed with apt-get if missing and
    install is true; None if it is missing and cannot be installed. Benchmarks only: morse never
    installs it."""
    exe = shutil.which("ccx") or shutil.which("ccx_2.20")
    if exe or not install:
        return exe
    print("installing calculix-ccx (Debian) for the peer comparison ...", flush=True)
    env = dict(os.environ, DEBIAN_FRONTEND="noninteractive")
    sudo = [] if os.geteuid() == 0 else ["sudo"]
    subprocess.run(sudo + ["apt-get", "update", "-qq"], env=env, check=False)
    p = subprocess.run(sudo + ["apt-get", "install", "-y", "-qq", "--no-install-recommends", "calculix-ccx"],
                       env=env)
    if p.returncode != 0:
        return None
    return shutil.which("ccx") or shutil.which("ccx_2.20")
