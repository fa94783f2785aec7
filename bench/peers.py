#!/usr/bin/python3
"""make bench: our engines against the peers (EDMD, SPARTA) in the same run, interleaved, medians.

usage: peers.py BUILD_DIR SRC_DIR PEERS_DIR [--reps K] [--quick] [--mc-only] [--mc-base DSMC_BENCH] [--work DIR]
--cpu: DSMC rates per CPU second instead of per wall-clock second (a machine shared with other work): ours
from dsmc_bench's cpu_seconds of the timed steps; SPARTA's from the CPU time of its run minus that of a run of
the same set-up with 1 timed step (getrusage of the children: set-up and start-up cancel).
--work: keep the peers' builds in DIR (reused by later runs) instead of a temporary directory.
--mc-only: the DSMC section only. --mc-base: an earlier build's dsmc_bench also runs at each DSMC point,
interleaved with ours and SPARTA (old, ours, peer, old, ours, peer, ...), and a line under the table gives
ours / old (medians of the same run).
Writes a markdown section to stdout (tables and notes generated from the numbers of this run) and one
JSON line per measurement to stderr. A peer that is absent or fails makes its rows say so.

Method (the developers' guide: machines are shared and their speed moves 20-30% between days, so a claim
is a ratio measured in one run): at each point every peer variant is run once to find the fastest
(the "screen"); then ours and that variant alternate K times (ours, peer, ours, peer, ...), and the row
gives both medians, their min-max spread and the ratio of the medians. Both sides are timed on the wall
clock, excluding set-up and warm-up, and simulate the same state (3D elastic hard spheres, diameter 1,
mass 1, T = 1, FCC start, the same N and packing fraction).
"""
import json, math, os, resource, statistics, subprocess, sys, tempfile

# 3D elastic points of issue 20: (N, phi, our warm-up and measured collisions per particle).
# N = 4 k^3 because EDMD starts from a filled FCC crystal (ours fills the same lattice exactly).
ED_POINTS = [(10976, 0.45, 200, 200), (10976, 0.1, 50, 100), (108000, 0.45, 100, 20),
             (108000, 0.1, 30, 20), (1048576, 0.45, 20, 4), (1048576, 0.1, 10, 4)]
EDMD_VARIANTS = ["Single", "Multi", "Cell"]
# DSMC against SPARTA: (N, phi, steps); 3D, elastic, 0.2 collisions per particle per step on both sides,
# the same cubic grid (ours chooses it; SPARTA is given the same number of cells per side).
# At 10^5 SPARTA's CPU rate is the difference of two runs (peers.py --cpu): 200 timed steps (about 1 CPU s of
# SPARTA) rather than 40 (0.2 s), whose difference spread by +-30% run to run (docs/benchmarks.md).
MC_POINTS = [(100000, 0.05, 200), (1000000, 0.05, 8), (10000000, 0.05, 4)]
ED_TARGET, MC_TARGET = 2.0, 3.0


def log(d):
    sys.stderr.write(json.dumps(d) + "\n")
    sys.stderr.flush()


def run(cmd, timeout=1800):
    p = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout)
    if p.returncode != 0:
        raise RuntimeError("%s: exit %d: %s" % (" ".join(cmd), p.returncode, p.stderr.strip()[-300:]))
    return p.stdout.strip().splitlines()[-1]


def enskog_rate(phi):
    """Collisions per particle per unit time of 3D hard spheres (sigma = m = T = 1), Carnahan-Starling g."""
    n = 6 * phi / math.pi
    g = (1 - phi / 2) / (1 - phi) ** 3
    return 4 * n * math.sqrt(math.pi) * g


def fmt(x):
    return "%.3g" % x


def spread(v):
    return "%s-%s" % (fmt(min(v)), fmt(max(v)))


def ed_section(build, peers, reps, work):
    ours_cmd = lambda n, phi, w, m: [os.path.join(build, "bench", "ed_bench"), "3", str(n), str(phi), "1", str(w), str(m)]
    edmd = os.path.join(peers, "edmd-run") if peers else None
    rows, notes_ratio = [], []
    for n, phi, w, m in ED_POINTS:
        rate = enskog_rate(phi)
        # EDMD prints a status line per unit of time and is timed between them: whole time units.
        pw, pm = max(1, math.ceil(w / rate)), max(2, math.ceil(m / rate))
        ocmd = ours_cmd(n, phi, w, m)
        peer_state = None
        best = None
        if edmd and os.path.exists(edmd):
            screen = {}
            for v in EDMD_VARIANTS:
                try:
                    line = run([sys.executable, edmd, v, str(n), str(phi), str(pw), str(pm), os.path.join(work, "edmd")])
                    screen[v] = float(line.split()[5])
                    log({"peer": "edmd", "screen": v, "n": n, "phi": phi, "line": line})
                except Exception as e:  # a variant that fails is reported, the others still count
                    screen[v] = None
                    log({"peer": "edmd", "screen": v, "n": n, "phi": phi, "error": str(e)})
            ok = {v: r for v, r in screen.items() if r}
            if ok:
                best = max(ok, key=ok.get)
                peer_state = screen
        ours, theirs = [], []
        for _ in range(reps):
            d = json.loads(run(ocmd))
            ours.append(d["collisions_per_second"])
            log({"ours": "ed", "n": n, "phi": phi, "collisions_per_second": d["collisions_per_second"]})
            if best:
                line = run([sys.executable, edmd, best, str(n), str(phi), str(pw), str(pm), os.path.join(work, "edmd")])
                theirs.append(float(line.split()[5]))
                log({"peer": "edmd", "variant": best, "n": n, "phi": phi, "line": line})
        mo = statistics.median(ours)
        cmd = "bench/ed_bench %s" % " ".join(ocmd[1:])
        if best:
            mp = statistics.median(theirs)
            ratio = mo / mp
            notes_ratio.append((n, phi, ratio))
            screen_txt = ", ".join("%s %s" % (v, fmt(r) if r else "failed") for v, r in peer_state.items())
            rows.append("| %d | %g | %s (%s) | %s (%s) | %s | **%.2f** | %s | `%s`; `edmd-run %s %d %g %d %d` |" % (
                n, phi, fmt(mo), spread(ours), fmt(mp), spread(theirs), best, ratio, screen_txt, cmd, best, n, phi, pw, pm))
        else:
            rows.append("| %d | %g | %s (%s) | peer not available | | | | `%s` |" % (n, phi, fmt(mo), spread(ours), cmd))
    out = ["### Event-driven MD against EDMD", "",
           "3D elastic hard spheres from the FCC crystal. Ours: `bench/ed_bench 3 N PHI 1 WARM MEASURE` (collisions per",
           "particle); EDMD: Smallenburg's code through `../shared/peers/edmd-run VARIANT N PHI WARM MEASURE` (simulated",
           "time, chosen from the Enskog collision rate so that both measure about the same collisions per particle).",
           "Collisions per second, median of %d interleaved runs (min-max in brackets); the screen is one run of each EDMD" % reps,
           "variant, the fastest of which is then the peer.", "",
           "| N | φ | ours coll/s | EDMD coll/s | EDMD variant | ours / EDMD | screen (coll/s) | commands |",
           "|---|---|---|---|---|---|---|---|"] + rows + [""]
    if notes_ratio:
        met = [r for r in notes_ratio if r[2] >= ED_TARGET]
        lo = min(notes_ratio, key=lambda r: r[2])
        hi = max(notes_ratio, key=lambda r: r[2])
        out.append("Generated from this run: ours / EDMD ranges from %.2f (N = %d, φ = %g) to %.2f (N = %d, φ = %g); the"
                   " target of %gx EDMD's best variant is met at %d of %d points%s." % (
                       lo[2], lo[0], lo[1], hi[2], hi[0], hi[1], ED_TARGET, len(met), len(notes_ratio),
                       "" if len(met) == len(notes_ratio) else
                       " (not at: %s)" % ", ".join("N = %d φ = %g" % (r[0], r[1]) for r in notes_ratio if r[2] < ED_TARGET)))
    else:
        out.append("EDMD was not available in this run (../shared/peers/edmd-run): no ratio is claimed.")
    out.append("")
    return out


def prepare_sparta(src, peers, work):
    """Build SPARTA once into WORK/sparta (what sparta-run would do), adding the accelerator_kokkos.h its
    KOKKOS-less tree lacks (bench/peer-fixes/). Returns None, or why the peer is not available."""
    tree = os.path.join(work, "sparta")
    if os.path.exists(os.path.join(tree, "sparta", "src", "spa_serial")):
        return None
    try:
        os.makedirs(tree, exist_ok=True)
        subprocess.run(["cp", "-r", os.path.join(peers, "sparta"), tree], check=True)
        hdr = os.path.join(tree, "sparta", "src", "accelerator_kokkos.h")
        if not os.path.exists(hdr):
            subprocess.run(["cp", os.path.join(src, "bench", "peer-fixes", "sparta_accelerator_kokkos.h"), hdr], check=True)
        subprocess.run(["make", "-j%d" % os.cpu_count(), "serial"], cwd=os.path.join(tree, "sparta", "src"), check=True,
                       stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    except Exception as e:
        return "SPARTA did not build: %s" % e
    return None


def child_cpu():
    r = resource.getrusage(resource.RUSAGE_CHILDREN)
    return r.ru_utime + r.ru_stime


def mc_section(build, src, peers, reps, work, base=None, cpu=False):
    rate = lambda d: d["moves"] / d["cpu_seconds"] if cpu else d["moves_per_second"]
    sparta = os.path.join(peers, "sparta-run") if peers else None
    why = prepare_sparta(src, peers, work) if sparta and os.path.exists(sparta) else "no ../shared/peers/sparta-run"
    if why:
        log({"peer": "sparta", "error": why})
        sparta = None
    rows, ratios, olds = [], [], []
    for n, phi, steps in MC_POINTS:
        ocmd = [os.path.join(build, "bench", "dsmc_bench"), "dsmc", "3", str(n), str(phi), "1", str(steps)]
        ours, theirs, old, cells = [], [], [], None
        have = sparta and os.path.exists(sparta)
        for _ in range(reps):
            if base:
                d = json.loads(run([base] + ocmd[1:]))
                old.append(rate(d))
                log({"base": "dsmc", "n": n, "phi": phi, "moves_per_second": d["moves_per_second"], "rate": rate(d)})
            d = json.loads(run(ocmd))
            ours.append(rate(d))
            cells = d["cells"][0]
            log({"ours": "dsmc", "n": n, "phi": phi, "moves_per_second": d["moves_per_second"], "rate": rate(d), "cells": d["cells"]})
            if have:
                try:
                    scmd = lambda k: [sys.executable, sparta, str(n), str(phi), str(cells), str(k), "0.2", os.path.join(work, "sparta")]
                    c0 = child_cpu()
                    line = run(scmd(steps))
                    c1 = child_cpu()
                    if cpu:
                        run(scmd(1))   # the same set-up, 1 warm-up and 1 timed step
                        c2 = child_cpu()
                        # sparta-run takes max(1, STEPS // 4) warm-up steps, then STEPS
                        extra = steps + max(1, steps // 4) - 2
                        theirs.append(n * extra / ((c1 - c0) - (c2 - c1)))
                    else:
                        theirs.append(float(line.split()[5]))
                    log({"peer": "sparta", "n": n, "phi": phi, "line": line, "rate": theirs[-1]})
                except Exception as e:
                    log({"peer": "sparta", "n": n, "phi": phi, "error": str(e)})
                    have = False
        mo = statistics.median(ours)
        if old:
            olds.append((n, mo / statistics.median(old), statistics.median(old)))
        cmd = "bench/dsmc_bench %s" % " ".join(ocmd[1:])
        if theirs:
            mp = statistics.median(theirs)
            ratios.append((n, mo / mp))
            rows.append("| %d | %g | %d^3 | %s (%s) | %s (%s) | **%.2f** | `%s`; `sparta-run %d %g %d %d 0.2` |" % (
                n, phi, cells, fmt(mo), spread(ours), fmt(mp), spread(theirs), mo / mp, cmd, n, phi, cells, steps))
        else:
            rows.append("| %d | %g | %d^3 | %s (%s) | peer not available | | `%s` |" % (n, phi, cells, fmt(mo), spread(ours), cmd))
    out = ["### DSMC against SPARTA", "",
           "3D elastic gas (SPARTA has no inelastic rule; the cost of a move or a collision is the same), the same number",
           "of particles, the same cubic grid and 0.2 collisions per particle per step on both sides. Moves per %ssecond (one" % ("CPU " if cpu else ""),
           "particle advanced by one step), median of %d interleaved runs (min-max in brackets), after untimed warm-up steps." % reps]
    if cpu:
        out += ["Per CPU second: ours from the timed steps' CPU time; SPARTA's from the CPU time of its run less that of the",
                "same set-up run with one timed step (peers.py --cpu)."]
    out += ["", "| N | φ | cells | ours moves/s | SPARTA moves/s | ours / SPARTA | commands |", "|---|---|---|---|---|---|---|"] + rows + [""]
    if ratios:
        met = [r for r in ratios if r[1] >= MC_TARGET]
        out.append("Generated from this run: ours / SPARTA is %s; the target of %gx is met at %d of %d sizes." % (
            ", ".join("%.2f at N = %d" % (r[1], r[0]) for r in ratios), MC_TARGET, len(met), len(ratios)))
    else:
        out.append("SPARTA was not available in this run (%s): no ratio is claimed." % (why or "it failed; see the log"))
    if olds:
        out.append("")
        out.append("The baseline build (`%s`), in the same interleaved runs: ours / baseline is %s (baseline medians %s moves/s)." % (
            base, ", ".join("%.2f at N = %d" % (r[1], r[0]) for r in olds), ", ".join(fmt(r[2]) for r in olds)))
    out.append("")
    return out


def main():
    args = sys.argv[1:]
    if len(args) < 3:
        sys.exit(__doc__)
    build, src, peers = args[0], args[1], args[2]
    reps = int(args[args.index("--reps") + 1]) if "--reps" in args else 5
    if "--quick" in args:  # a smoke run of the script itself: the smallest points only
        global ED_POINTS, MC_POINTS
        ED_POINTS, MC_POINTS = ED_POINTS[:1], MC_POINTS[:1]
    base = args[args.index("--mc-base") + 1] if "--mc-base" in args else None
    if not os.path.isdir(peers):
        peers = None
    def sections(work):
        out = ["## Against the peers, in this run", ""]
        if "--mc-only" not in args:
            out += ed_section(build, peers, reps, work)
        out += mc_section(build, src, peers, reps, work, base, "--cpu" in args)
        return out
    if "--work" in args:
        work = os.path.abspath(args[args.index("--work") + 1])
        os.makedirs(work, exist_ok=True)
        out = sections(work)
    else:
        with tempfile.TemporaryDirectory(prefix="granulard-peers-") as work:
            out = sections(work)
    print("\n".join(out))


if __name__ == "__main__":
    main()
