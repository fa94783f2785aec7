#!/usr/bin/python3
"""The speed/accuracy trade on bounded scenes (issue 13): seed 000's gravity box (A12) and vibrated bed (A11).

usage: bench/tradeoff_bounded.py ENGINE DOCDIR [--quick]

For each scene: event-driven MD (exact for hard disks) with SEEDS seeds is the reference; dsmc (correction
none, enskog, and cba: the seed's DSMC2, with the contact value at the mean and, "local chi", at the local volume fraction)
and hsmc (cba) run the same scene, same seeds, at the scene's settings and at coarser and
finer ones. Writes DOCDIR/tradeoff-bounded.md (one table per scene, the Pareto front marked) and
DOCDIR/tradeoff-bounded.png (error against cost per scene, the front drawn as a line); bench/tradeoff.py
includes the table in docs/tradeoff.md.

- Gravity box: 100 inelastic disks (e = 0.9, d = 0.001 m) fall in a 0.02 x 0.04 m box (presets/
  gravity-box-2d.json) to t = 0.5 s; also soft-sphere MD (method md, frictionless, no TC) at two stiffnesses. Observable: the centre-of-mass height h(t) at 10 times 0.05 .. 0.5 s.
  Error: relative RMS over those times of (mean h_MC / mean h_ED - 1).
- Vibrated bed: 56 disks (e = 0.9) on a floor vibrating at 100 Hz (presets/vibrated-bed-2d.json, r_w = 1) at
  V = 2 pi f A = 0.1, 0.3 and 1.2 m/s (below and above where the seed finds DSMC failing, 0.6 m/s; the seed's
  DSMC2 matched ED down to 0.06 m/s), to 2 s.
  Observable: the time mean of h over [0.5, 2] s. Error: relative error of H - H_floor (H_floor = one radius,
  the height of a monolayer at rest), the part of the height the vibration makes.
- Cost: CPU seconds per unit simulated time per particle, from the engine's own wall_seconds (one run at a
  time), mean over the seeds.
- ref SE: the relative standard error of ED's mean over its seeds: an MC error at or below it is not resolved.
"""
import json, math, os, statistics, subprocess, sys, tempfile, time

args = [a for a in sys.argv[1:] if not a.startswith("--")]
QUICK = "--quick" in sys.argv
ENGINE, DOCDIR = args[0], args[1]
SRC = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
SEEDS = 3 if QUICK else 6
t_start = time.time()


def preset(name):
    return json.load(open(os.path.join(SRC, "presets", name)))


def run(scene):
    """Run the engine on scene: the progress records (dicts) and the summary."""
    with tempfile.NamedTemporaryFile("w", suffix=".json", delete=False) as fh:
        json.dump(scene, fh)
    try:
        p = subprocess.run([ENGINE, "run", fh.name], capture_output=True, text=True)
    finally:
        os.unlink(fh.name)
    recs = [json.loads(l) for l in p.stdout.splitlines() if l.startswith("{")]
    prog = [r for r in recs if r.get("type") == "progress"]
    summ = [r for r in recs if r.get("type") == "summary"]
    if p.returncode != 0 or not summ:
        raise SystemExit("engine failed (%d): %s" % (p.returncode, p.stderr.strip()[:300]))
    return prog, summ[0]


def mean_se(xs):
    """Mean and its standard error (sample standard deviation / sqrt(n))."""
    return statistics.fmean(xs), statistics.stdev(xs) / math.sqrt(len(xs)) if len(xs) > 1 else float("nan")


# Variants: (method, correction, label of the setting, method settings)
def variants(base_mc):
    cell = base_mc.get("cell_size", 2)
    out = []
    # dsmc/cba is the seed's DSMC2 (the Enskog rate and the CBA offset, seed 000 sec. 3.7)
    for method, corr in (("dsmc", "none"), ("dsmc", "enskog"), ("dsmc", "cba"), ("hsmc", "cba")):
        settings = [("scene's (cell %g)" % cell, dict(base_mc)),
                    ("cell %g" % (2 * cell), dict(base_mc, cell_size=2 * cell))]
        if "time_step" in base_mc:
            settings.append(("step / 4", dict(base_mc, time_step=base_mc["time_step"] / 4)))
            settings.append(("step x 4", dict(base_mc, time_step=base_mc["time_step"] * 4)))
        else:
            settings.append(("0.05 coll/step", dict(base_mc, collisions_per_step=0.05)))
            settings.append(("0.8 coll/step", dict(base_mc, collisions_per_step=0.8)))
        for label, st in settings:
            st = dict(st)
            st["correction"] = corr
            out.append((method, corr, label, st))
    # the seed's DSMC2 evaluates the Enskog factor at the local density: contact_value "local" (cut at the walls)
    for method in ("dsmc", "hsmc"):
        out.append((method, "cba", "scene's, local chi", dict(base_mc, correction="cba", contact_value="local")))
    return out


def scene_for(base, method, mc, seed, until, every, observables):
    s = json.loads(json.dumps(base))
    s["method"] = method
    s.pop("hsmc", None)
    s.pop("dsmc", None)
    if method == "md":   # soft spheres: no TC (no collapse to guard against)
        s.get("collisions", {}).pop("tc", None)
    if method != "ed":
        s[method] = mc
    s["run"] = {"seed": seed, "until": {"time": until}}
    s["output"] = {"every": {"time": every}, "observables": observables}
    return s


def measure(base, method, mc, until, every, reduce_fn):
    """SEEDS runs: per seed the observable vector (reduce_fn(progress)) and the cost."""
    vals, costs, warn = [], [], False
    for k in range(SEEDS):
        prog, summ = run(scene_for(base, method, mc, 100 + k, until, every, ["center_of_mass_height"]))
        vals.append(reduce_fn(prog))
        costs.append(summ["wall_seconds"] / (until * summ.get("particles", base["particles"]["count"])))
        warn |= any("warning" in r for r in prog)
    return vals, sum(costs) / len(costs), warn


def pareto(rows):
    """Mark the rows not dominated in (cost, error): no other row is cheaper and at least as accurate. An
    error below the reference's own SE (rows[0]) is not resolved: it counts as that SE."""
    floor = rows[0]["err"]
    e = lambda r: max(r["err"], floor)
    for r in rows:
        r["front"] = not any(o is not r and o["cost"] <= r["cost"] and e(o) <= e(r) and
                             (o["cost"] < r["cost"] or e(o) < e(r)) for o in rows)


scenes = []

# ---- gravity box (A12) -------------------------------------------------------
gb = preset("gravity-box-2d.json")
times = [0.05 * (k + 1) for k in range(10)]


def heights(prog):
    """h at each of times: the first record at or after it (md records come at the end of the step that
    reaches an output time, a step of ~1e-6 s here; the other methods land on it)."""
    prog = sorted(prog, key=lambda r: r["time"])
    return [next(r["center_of_mass_height"] for r in prog if r["time"] >= t - 1e-12) for t in times]


ed_vals, ed_cost, _ = measure(gb, "ed", None, 0.5, 0.05, heights)
ed_mean = [mean_se([v[k] for v in ed_vals]) for k in range(len(times))]
ref_se = math.sqrt(sum((se / m) ** 2 for m, se in ed_mean) / len(times))
rows = [{"method": "ed", "setting": "reference (%d seeds)" % SEEDS, "cost": ed_cost, "err": ref_se, "warn": False,
         "detail": "late h %.3g mm" % (1e3 * sum(m for m, _ in ed_mean[-3:]) / 3), "curve": [m for m, _ in ed_mean]}]
for method, corr, label, mc in variants(gb.get("hsmc", {})):
    vals, cost, warn = measure(gb, method, mc, 0.5, 0.05, heights)
    mean = [mean_se([v[k] for v in vals])[0] for k in range(len(times))]
    err = math.sqrt(sum((m / e[0] - 1) ** 2 for m, e in zip(mean, ed_mean)) / len(times))
    rows.append({"method": "%s/%s" % (method, corr), "setting": label, "cost": cost, "err": err, "warn": warn,
                 "detail": "late h %.3g mm" % (1e3 * sum(mean[-3:]) / 3), "curve": mean})
# soft-sphere MD (issue 18: the seed's fourth method in A12), frictionless, at its default stiffness (a head-on
# impact at the default impact speed overlaps 1% of a diameter) and a softer one (5%)
for label, md in (("default (overlap 0.01)", {}), ("overlap 0.05", {"max_overlap": 0.05})):
    vals, cost, warn = measure(gb, "md", md, 0.5, 0.05, heights)
    mean = [mean_se([v[k] for v in vals])[0] for k in range(len(times))]
    err = math.sqrt(sum((m / e[0] - 1) ** 2 for m, e in zip(mean, ed_mean)) / len(times))
    rows.append({"method": "md", "setting": label, "cost": cost, "err": err, "warn": warn,
                 "detail": "late h %.3g mm" % (1e3 * sum(mean[-3:]) / 3), "curve": mean})
pareto(rows)
scenes.append(("Gravity box (seed 000 A12): centre-of-mass height h(t), t = 0.05 .. 0.5 s", "gravity box", rows))

# ---- vibrated bed (A11) ------------------------------------------------------
vb = preset("vibrated-bed-2d.json")
f = vb["boundaries"]["y"]["lower"]["frequency"]
rad = vb["particles"]["radius"]
for V in (0.1, 0.3, 1.2):
    base = json.loads(json.dumps(vb))
    base["boundaries"]["y"]["lower"]["amplitude"] = V / (2 * math.pi * f)
    base["boundaries"]["y"]["lower"]["restitution"] = 1


    def hmean(prog):
        hs = [r["center_of_mass_height"] for r in prog if r["time"] >= 0.5 - 1e-9]
        return sum(hs) / len(hs)


    ed_vals, ed_cost, _ = measure(base, "ed", None, 2.0, 0.01, hmean)
    H, Hse = mean_se(ed_vals)
    rows = [{"method": "ed", "setting": "reference (%d seeds)" % SEEDS, "cost": ed_cost, "err": Hse / (H - rad),
             "warn": False, "detail": "H %.4g mm" % (1e3 * H)}]
    for method, corr, label, mc in variants(vb.get("hsmc", {})):
        vals, cost, warn = measure(base, method, mc, 2.0, 0.01, hmean)
        m = sum(vals) / len(vals)
        rows.append({"method": "%s/%s" % (method, corr), "setting": label, "cost": cost,
                     "err": abs(m - H) / (H - rad), "warn": warn, "detail": "H %.4g mm" % (1e3 * m)})
    pareto(rows)
    scenes.append(("Vibrated bed (seed 000 A11), V = %g m/s at 100 Hz: mean height H over 0.5 .. 2 s, error "
                   "relative to H - radius" % V, "vibrated bed V=%g" % V, rows))

# ---- report --------------------------------------------------------------------
md = os.path.join(DOCDIR, "tradeoff-bounded.md")
png = os.path.join(DOCDIR, "tradeoff-bounded.png")
with open(md, "w") as fh:
    fh.write("## Bounded scenes (issue 13)\n\n")
    fh.write("Written by `make bench` (`bench/tradeoff_bounded.py ENGINE DOCDIR`; %d seeds per point, %.0f s, %s). "
             "The method: the docstring of bench/tradeoff_bounded.py. `front`: on the Pareto front of its scene (no "
             "other row is cheaper and at least as accurate; an error below ED's SE counts as that SE, since it is "
             "not resolved). `warn`: the engine's validity warning fired.\n\n"
             % (SEEDS, time.time() - t_start, time.strftime("%Y-%m-%d", time.gmtime())))
    fh.write("![error vs cost on bounded scenes](tradeoff-bounded.png)\n\n")
    for title, _, rows in scenes:
        fh.write("### %s\n\n" % title)
        fh.write("| method | setting | cost (s per time per particle) | error | front | warn | measured |\n")
        fh.write("|---|---|---|---|---|---|---|\n")
        for r in rows:
            fh.write("| %s | %s | %.3g | %.3g | %s | %s | %s |\n" % (r["method"], r["setting"], r["cost"], r["err"],
                     "yes" if r["front"] else "", "yes" if r["warn"] else "", r["detail"]))
        fh.write("\n")
        if rows is scenes[0][2]:
            fh.write("![gravity box: h(t) per method](tradeoff-gravity-box.png)\n\n")
try:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, axes = plt.subplots(1, len(scenes), figsize=(5 * len(scenes), 4.6))
    colour = {"ed": "black", "md": "tab:green", "dsmc/none": "tab:red", "dsmc/enskog": "tab:orange", "dsmc/cba": "tab:purple",
              "hsmc/cba": "tab:blue"}
    for ax, (_, short, rows) in zip(axes, scenes):
        for r in rows:
            ax.scatter(r["cost"], max(r["err"], 1e-4), color=colour[r["method"]], marker="*" if r["method"] == "ed" else "o",
                       s=90 if r["method"] == "ed" else 30, label=r["method"])
        front = sorted((r for r in rows if r["front"]), key=lambda r: r["cost"])
        ax.step([r["cost"] for r in front], [max(r["err"], 1e-4) for r in front], where="post", color="grey",
                alpha=0.6, label="Pareto front")
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_title(short)
        ax.set_xlabel("cost: CPU s per unit time per particle")
        ax.grid(True, which="both", alpha=0.3)
        h, l = ax.get_legend_handles_labels()
        seen = {}
        for hh, ll in zip(h, l):
            seen.setdefault(ll, hh)
        ax.legend(seen.values(), seen.keys(), fontsize=7)
    axes[0].set_ylabel("error against ED (ED star: its own SE)")
    fig.tight_layout()
    fig.savefig(png, dpi=100)
    # seed 000 Figs 2.6/2.7: h(t) of the gravity box, each method at its scene's setting, MD at its default
    fig, ax = plt.subplots(figsize=(6, 4.2))
    for r in scenes[0][2]:
        if r["method"] == "ed" or r["setting"].startswith("scene's (") or r["setting"].startswith("default"):
            ax.plot(times, [1e3 * h for h in r["curve"]], marker="o", ms=3,
                    color=colour[r["method"]], lw=2.5 if r["method"] == "ed" else 1.2, label=r["method"])
    ax.set_xlabel("t (s)")
    ax.set_ylabel("centre-of-mass height (mm)")
    ax.set_title("gravity box (seed 000 A12), mean of %d seeds" % SEEDS)
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(os.path.join(DOCDIR, "tradeoff-gravity-box.png"), dpi=100)
except ImportError:
    print("matplotlib missing (apt-get install python3-matplotlib): no plot", file=sys.stderr)
print("wrote", md, "in %.0f s" % (time.time() - t_start), file=sys.stderr)
