#!/usr/bin/python3
"""The trade, measured: cost and error of DSMC/HSMC against event-driven MD on homogeneous cooling and clustering.

usage: tradeoff.py ENGINE DOCDIR [--quick]
Runs granular-engine on generated scenes, writes DOCDIR/tradeoff.md and DOCDIR/tradeoff.png.
Error = relative RMS of T(t)/T_ED(t) - 1 over the output times; the ED reference is itself an
ensemble of replicas, so its own relative standard error is shown next to it (an MC error at or
below it is not resolved). Cost = CPU seconds per unit simulated time per particle (wall time of
a serial run / (replicas * t_end * N)).
"""
import json, math, os, platform, subprocess, sys, tempfile, time

ENGINE, DOCDIR = sys.argv[1], sys.argv[2]
QUICK = "--quick" in sys.argv
R = 4                      # replicas per point (ED and MC alike)
K = 10                     # output times
N2, N3 = (1000, 1000) if QUICK else (2000, 2000)


def g_contact(dim, nu):
    return (1 - 7 * nu / 16) / (1 - nu) ** 2 if dim == 2 else (1 - nu / 2) / (1 - nu) ** 3


def f_enskog(dim, nu):      # collision frequency per particle at T = 1, diameter 1, mass 1
    return dim * 2 ** (dim - 1) / (math.sqrt(math.pi) * 0.5) * nu * g_contact(dim, nu)


def run(scene):
    with tempfile.NamedTemporaryFile("w", suffix=".json", delete=False) as f:
        json.dump(scene, f)
        path = f.name
    t0 = time.time()
    out = subprocess.run([ENGINE, "run", path], capture_output=True, text=True)
    wall = time.time() - t0
    os.unlink(path)
    if out.returncode != 0:
        raise RuntimeError(out.stderr.strip())
    lines = [json.loads(l) for l in out.stdout.splitlines()]
    prog = [l for l in lines if l["type"] == "progress"]
    return prog, lines[-1], wall


def case_scene(c, method, extra):
    sc = {"method": method, "dimensions": c["dim"],
          "particles": {"count": c["n"], "volume_fraction": c["nu"], "initial": {"positions": "random"}},
          "collisions": {"restitution": c["e"]},
          "run": {"seed": 17, "until": {"time": c["t_end"]}, "replicas": R},
          "output": {"every": {"time": c["t_end"] / K}, "observables": ["temperature"]}}
    if method == "ed":
        sc["particles"]["initial"] = {"positions": "lattice", "relax": {"collisions_per_particle": 10}}
        if c["e"] < 0.8:
            sc["collisions"]["tc"] = 1e-4 / f_enskog(c["dim"], c["nu"])
    else:
        sc["particles"]["initial"]["relax"] = {"collisions_per_particle": 10}
        sc[method] = extra
    return sc


def cases():
    out = []
    for dim, nus in ((2, (0.05, 0.4)), (3, (0.05, 0.25))):
        for nu in nus:
            for e in (0.9, 0.5):
                lam = 1 - e * e
                tau_end = 2.0                       # Haff time: T/T0 = 1/9 at the end
                t_end = tau_end * 2 * dim / (lam * f_enskog(dim, nu))
                out.append(dict(name="%dD nu=%g e=%g" % (dim, nu, e), dim=dim, nu=nu, e=e, t_end=t_end,
                                n=N2 if dim == 2 else N3, kind="cooling"))
    # Clustering (seed 000 sec. 3.2, scaled down): 2D nu=0.25, e=0.8 to t/t0 = 10.
    dim, nu, e = 2, 0.25, 0.8
    t0 = math.sqrt(math.pi) / (math.sqrt(2) * (1 - e * e) * nu / g_contact(dim, nu)) * 1.0
    out.append(dict(name="clustering 2D nu=0.25 e=0.8", dim=dim, nu=nu, e=e,
                    t_end=10 * 2 * dim / ((1 - e * e) * f_enskog(dim, nu)), n=4000 if not QUICK else 2000,
                    kind="clustering"))
    return out


def variants(c):
    dense = c["nu"] > 0.1
    corr = "enskog" if dense else "none"
    v = []
    for method, cr in (("dsmc", corr), ("hsmc", "cba")):
        v.append((method, {"correction": cr}, "auto cell, 0.2 coll/step"))
        for cps in (0.05, 0.8):
            v.append((method, {"correction": cr, "collisions_per_step": cps}, "auto cell, %g coll/step" % cps))
        for cell in (1, 2, 4, 8):
            if method == "hsmc" and cell < 2:
                continue
            v.append((method, {"correction": cr, "cell_size": cell}, "cell %g, 0.2 coll/step" % cell))
    return v


rows = []
for c in cases():
    ref, refsum, refwall = run(case_scene(c, "ed", None))
    tref = [p["temperature"] for p in ref[1:]]
    seref = [p["temperature_se"] / p["temperature"] for p in ref[1:]]
    ref_se = math.sqrt(sum(s * s for s in seref) / len(seref))
    cost_ed = refwall / (R * c["t_end"] * c["n"])
    rows.append(dict(case=c["name"], method="ed", setting="reference (%d replicas)" % R, cost=cost_ed,
                     err=ref_se, ref_se=ref_se, warn=""))
    print(c["name"], "ed", cost_ed, ref_se, file=sys.stderr)
    for method, extra, label in variants(c):
        try:
            prog, summ, wall = run(case_scene(c, method, extra))
        except RuntimeError as ex:
            print("skip", c["name"], method, label, ex, file=sys.stderr)
            continue
        t = [p["temperature"] for p in prog[1:]]
        err = math.sqrt(sum((a / b - 1) ** 2 for a, b in zip(t, tref)) / len(t))
        rows.append(dict(case=c["name"], method=method + "/" + extra["correction"], setting=label,
                         cost=wall / (R * c["t_end"] * c["n"]), err=err, ref_se=ref_se,
                         warn="yes" if prog[0].get("warning") else ""))
        print(c["name"], method, label, rows[-1]["cost"], err, file=sys.stderr)

md = os.path.join(DOCDIR, "tradeoff.md")
png = os.path.join(DOCDIR, "tradeoff.png")
cmd = "make bench (bench/tradeoff.py ENGINE DOCDIR%s)" % (" --quick" if QUICK else "")
with open(md, "w") as f:
    f.write("# The trade: cost against accuracy, DSMC/HSMC vs event-driven MD\n\n")
    f.write("Written by `%s`; numbers from the last run. Do not edit by hand.\n\n" % cmd)
    f.write("- Machine: %s, %d cores; one engine run at a time, serial (wall time).\n" % (platform.processor() or platform.machine(), os.cpu_count()))
    f.write("- Date: %s.\n" % time.strftime("%Y-%m-%d", time.gmtime()))
    f.write("- Homogeneous cooling from an equilibrated elastic state (10 collisions per particle), periodic box, diameter 1,\n"
            "  mass 1, T0 = 1, to Haff time tau = 2 (T/T0 = 1/9 if homogeneous); N = %d (2D), %d (3D). Clustering: 2D, nu = 0.25,\n"
            "  e = 0.8, to tau = 10 (clusters form; Haff's law no longer holds).\n" % (N2, N3))
    f.write("- Reference: event-driven MD (exact for hard spheres), %d replicas; `ref SE` is its relative standard error\n"
            "  of T (RMS over the output times): an MC error at or below it is not resolved.\n" % R)
    f.write("- Error: relative RMS of T_MC(t)/T_ED(t) - 1 over %d output times, each MC point also %d replicas.\n" % (K, R))
    f.write("- Cost: CPU seconds per unit simulated time per particle. `warn`: the engine's validity warning fired.\n")
    f.write("- dsmc uses correction `none` at nu = 0.05 and `enskog` above; hsmc uses `cba` (Enskog rate + offset).\n\n")
    f.write("![error vs cost](tradeoff.png)\n\n")
    f.write("| case | method | setting | cost (s per time per particle) | error (rel. RMS) | ref SE | warn |\n|---|---|---|---|---|---|---|\n")
    for r in rows:
        f.write("| %s | %s | %s | %.3g | %.3g | %.2g | %s |\n" % (r["case"], r["method"], r["setting"], r["cost"], r["err"],
                                                           r["ref_se"], r["warn"]))
    notes = os.path.join(DOCDIR, "tradeoff-notes.md")
    if os.path.exists(notes):
        f.write("\n" + open(notes).read())

try:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, axes = plt.subplots(1, 2, figsize=(13, 5.5), sharey=True)
    marks = {"dsmc": "o", "hsmc": "s", "ed": "*"}
    names = sorted({r["case"] for r in rows})
    cmap = plt.get_cmap("tab10")
    for ax, (title, sel) in zip(axes, (("weak dissipation (e = 0.9) and clustering", lambda r: "e=0.9" in r["case"] or "clustering" in r["case"]),
                                       ("strong dissipation (e = 0.5)", lambda r: "e=0.5" in r["case"]))):
        for i, name in enumerate(names):
            for m in ("ed", "dsmc", "hsmc"):
                pts = [r for r in rows if r["case"] == name and r["method"].startswith(m) and sel(r)]
                if pts:
                    ax.scatter([p["cost"] for p in pts], [max(p["err"], 1e-4) for p in pts], marker=marks[m],
                               color=cmap(i % 10), s=60 if m == "ed" else 25,
                               label="%s %s" % (name, m) if m != "hsmc" else None)
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlabel("cost: CPU s per unit time per particle")
        ax.set_title(title)
        ax.grid(True, which="both", alpha=0.3)
    axes[0].set_ylabel("error: relative RMS of T(t) vs ED (ED star: its own SE)")
    axes[0].legend(fontsize=6, ncol=2)
    axes[1].legend(fontsize=6, ncol=2)
    fig.suptitle("circles dsmc, squares hsmc, stars ED reference")
    fig.tight_layout()
    fig.savefig(png, dpi=110)
except ImportError:
    print("matplotlib missing (apt-get install python3-matplotlib): no plot", file=sys.stderr)
print("wrote", md, file=sys.stderr)
