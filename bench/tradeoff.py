#!/usr/bin/python3
"""The trade, measured: cost and error of DSMC/HSMC against event-driven MD, and the advice model fitted to it.

usage: tradeoff.py ENGINE DOCDIR [--model MODEL.json] [--quick] [--rows ROWS.json] [--refit ROWS.json]
                   [--baseline OLD_ENGINE]
       tradeoff.py ENGINE DOCDIR --md MODEL.json
Runs granular-engine on generated scenes, writes DOCDIR/tradeoff.md, DOCDIR/tradeoff.png and (with --model)
the advice model that the build embeds (data/advice-model.json; format in docs/tradeoff-notes.md), then checks
the model on held-out scenes with `ENGINE advise --model`. --rows keeps the measurements (per output time);
--refit reads them instead of running (the fit and the held-out predictions only). --baseline: also show the
held-out predictions of another engine's built-in model (the model before a change).
--md: soft-sphere MD (method md, its default stiffness and step) against ed on the model's cooling grid: adds
cost.md and the error variant "md" to MODEL.json in place (the rest of the model is kept) and writes
DOCDIR/tradeoff-md.md. Both methods start from the same random placement (no relax: md has none), so the
error is md's dynamics only.
Error = relative RMS of T(t)/T_ED(t) - 1 over the output times; the ED reference is itself an ensemble of
replicas, so its own relative standard error is shown next to it. Cost = the engine's own production
wall_seconds (set-up and the elastic pre-run excluded; one rank, so replicas run one after another) per
replica, unit simulated time and particle.
"""
import json, math, os, platform, resource, subprocess, sys, tempfile, time

args = [a for a in sys.argv[1:] if not a.startswith("--")]
QUICK = "--quick" in sys.argv
def opt(name):
    return sys.argv[sys.argv.index(name) + 1] if name in sys.argv else None


MODEL, ROWS, REFIT, BASELINE = opt("--model"), opt("--rows"), opt("--refit"), opt("--baseline")
MD_MODEL = opt("--md")
DENSITY_AXIS = opt("--density-axis") or "contact_value"     # or volume_fraction: plain bilinear in nu
BASELINE_NOTE = "bilinear in (nu, lambda), no dependence on the run length: every run as if to Haff time 2"
args = [a for a in args if a not in (MODEL, ROWS, REFIT, BASELINE, DENSITY_AXIS, MD_MODEL)]
ENGINE, DOCDIR = args[0], args[1]
R = 4                      # replicas per point (ED and MC alike)
K = 10                     # output times
N = 2000 if QUICK else 20000
N_HELD = 1000 if QUICK else 8000
TAU_END = 2.0              # Haff time of the cooling runs: T/T0 = 1/9 if homogeneous
CPS = 0.2                  # the engine's default collisions per step
t_start = time.time()


def g_contact(dim, nu):
    return (1 - 7 * nu / 16) / (1 - nu) ** 2 if dim == 2 else (1 - nu / 2) / (1 - nu) ** 3


def f_enskog(dim, nu):      # collision frequency per particle at T = 1, diameter 1, mass 1
    return dim * 2 ** (dim - 1) / (math.sqrt(math.pi) * 0.5) * nu * g_contact(dim, nu)


def run(scene):
    with tempfile.NamedTemporaryFile("w", suffix=".json", delete=False) as f:
        json.dump(scene, f)
        path = f.name
    out = subprocess.run([ENGINE, "run", path], capture_output=True, text=True)
    os.unlink(path)
    if out.returncode != 0:
        raise RuntimeError(out.stderr.strip())
    lines = [json.loads(l) for l in out.stdout.splitlines()]
    return [l for l in lines if l["type"] == "progress"], lines[-1]


def advise(scene, engine=None):
    with tempfile.NamedTemporaryFile("w", suffix=".json", delete=False) as f:
        json.dump(scene, f)
        path = f.name
    cmd = [engine, "advise", path] if engine else [ENGINE, "advise", path, "--model", MODEL]
    out = subprocess.run(cmd, capture_output=True, text=True)
    os.unlink(path)
    if out.returncode != 0:
        raise RuntimeError(out.stderr.strip())
    return json.loads(out.stdout)


def case_scene(c, method, extra):
    until = {"time": c["t_end"]} if "cpp_end" not in c else {"collisions_per_particle": c["cpp_end"]}
    every = {"time": c["t_end"] / K} if "cpp_end" not in c else {"collisions_per_particle": c["cpp_end"] / K}
    sc = {"method": method, "dimensions": c["dim"],
          "particles": {"count": c["n"], "volume_fraction": c["nu"], "initial": {"positions": "random"}},
          "collisions": {"restitution": c["e"]},
          "run": {"seed": 17, "until": until, "replicas": R},
          "output": {"every": every, "observables": ["temperature"]}}
    if method == "ed":
        sc["particles"]["initial"] = {"positions": "lattice", "relax": {"collisions_per_particle": 10}}
        if c["e"] < 0.8:
            sc["collisions"]["tc"] = 1e-4 / f_enskog(c["dim"], c["nu"])
    else:
        sc["particles"]["initial"]["relax"] = {"collisions_per_particle": 10}
        if extra:
            sc[method] = extra
    return sc


def cooling_t_end(dim, nu, e, tau):
    return tau * 2 * dim / ((1 - e * e) * f_enskog(dim, nu))


def cases():
    out = []
    for dim, nus in ((2, (0.05, 0.4)), (3, (0.05, 0.25))):
        for nu in nus:
            for e in (0.9, 0.5):
                out.append(dict(name="%dD nu=%g e=%g" % (dim, nu, e), dim=dim, nu=nu, e=e,
                                t_end=cooling_t_end(dim, nu, e, TAU_END), n=N, kind="cooling"))
    # Clustering (seed 000 sec. 3.2, scaled down): 2D nu=0.25, e=0.8 to Haff time 10.
    out.append(dict(name="clustering 2D nu=0.25 e=0.8", dim=2, nu=0.25, e=0.8, t_end=cooling_t_end(2, 0.25, 0.8, 10),
                    n=N, kind="clustering"))
    return out


DEFAULT = "auto cell, %g coll/step" % CPS


def variants(c):
    sweep = "enskog" if c["nu"] > 0.1 else "none"
    v = []
    for method, cr in (("dsmc", "none"), ("dsmc", "enskog"), ("hsmc", "cba")):
        v.append((method, cr, {"correction": cr}, DEFAULT))
        for cps in (0.05, 0.8):
            v.append((method, cr, {"correction": cr, "collisions_per_step": cps}, "auto cell, %g coll/step" % cps))
    for method, cr, cells in (("dsmc", sweep, (1, 2, 4, 8)), ("hsmc", "cba", (2, 4, 8))):
        for cell in cells:
            v.append((method, cr, {"correction": cr, "cell_size": cell}, "cell %g, %g coll/step" % (cell, CPS)))
    return v


def rms(v):
    return math.sqrt(sum(x * x for x in v) / len(v)) if v else float("nan")


def ses(prog):             # relative SE of T at each output time (t = 0 excluded)
    return [p["temperature_se"] / p["temperature"] for p in prog[1:]]


def rel_se(prog):
    return rms(ses(prog))


def devs(prog, tref):      # T_MC / T_ED - 1 at each output time
    return [a["temperature"] / b - 1 for a, b in zip(prog[1:], tref)]


def rel_err(prog, tref):
    return rms(devs(prog, tref))


def lsq2(xs, ys, ws):
    """Least squares y = p0 x0 + p1 x1 with weights, both >= 0 (the smaller one set to 0 if negative)."""
    def solve(cols):
        if len(cols) == 1:
            k = cols[0]
            num = sum(w * x[k] * y for x, y, w in zip(xs, ys, ws))
            den = sum(w * x[k] * x[k] for x, w in zip(xs, ws))
            p = [0.0, 0.0]
            p[k] = max(num / den, 0.0) if den > 0 else 0.0
            return p
        a = [[sum(w * x[i] * x[j] for x, w in zip(xs, ws)) for j in (0, 1)] for i in (0, 1)]
        b = [sum(w * x[i] * y for x, y, w in zip(xs, ys, ws)) for i in (0, 1)]
        det = a[0][0] * a[1][1] - a[0][1] * a[1][0]
        if det == 0:
            return None
        return [(b[0] * a[1][1] - b[1] * a[0][1]) / det, (a[0][0] * b[1] - a[1][0] * b[0]) / det]
    p = solve([0, 1])
    if p is None or min(p) < 0:
        cands = [solve([0]), solve([1])]
        def sse(q):
            return sum(w * (q[0] * x[0] + q[1] * x[1] - y) ** 2 for x, y, w in zip(xs, ys, ws))
        p = min(cands, key=sse)
    return p


def round_sig(o):
    if isinstance(o, float):
        return float("%.4g" % o)
    if isinstance(o, dict):
        return {k: round_sig(v) for k, v in o.items()}
    if isinstance(o, list):
        return [round_sig(v) for v in o]
    return o


def curves(p, var):
    """bias(tau_k), spread(tau_k) of one measured row: over the output times up to the k-th (the error of a run
    that stops there, as the RMS over its outputs), measured error^2 = bias^2 + SE_MC^2 + SE_ref^2; bias made
    non-decreasing (a longer run cannot have a smaller bias than the part it starts with); spread = SE x
    sqrt(N x replicas)."""
    bias, spread, b = [], [], 0.0
    for k in range(1, len(p["dev"]) + 1):
        ms_dev = sum(d * d for d in p["dev"][:k]) / k
        ms_se = sum(x * x for x in p["ses"][:k]) / k
        ms_ref = sum(x * x for x in p["ref_ses"][:k]) / k
        if var != "ed":
            b = max(b, math.sqrt(max(0.0, ms_dev - ms_se - ms_ref)))
        bias.append(b)
        spread.append(math.sqrt(ms_se) * math.sqrt(p["c"]["n"] * R))
    return bias, spread


MD_N = 200 if QUICK else 2000   # md's cost per step hardly depends on N (cell lists); its bias does not at all
if MD_MODEL:
    model = json.load(open(MD_MODEL))
    model["cost"]["md"] = {}
    table = []
    for dim in (2, 3):
        grid = model["error"][str(dim)]
        mdrows = {}
        for nu in grid["volume_fraction"]:
            for lam in grid["lambda"]:
                e = math.sqrt(1 - lam)
                c = dict(name="%dD nu=%g e=%.3g" % (dim, nu, e), dim=dim, nu=nu, e=e,
                         t_end=cooling_t_end(dim, nu, e, TAU_END), n=MD_N, kind="cooling")
                rsc = case_scene(c, "ed", None)
                rsc["particles"]["initial"] = {"positions": "random"}
                msc = case_scene(c, "md", None)
                del msc["particles"]["initial"]["relax"]
                ref, _ = run(rsc)
                # cost: the CPU time of the md process (user + system; placement included, a few per cent of
                # the shortest run), not its wall time: the machine is shared
                ru0 = resource.getrusage(resource.RUSAGE_CHILDREN)
                prog, summ = run(msc)
                ru1 = resource.getrusage(resource.RUSAGE_CHILDREN)
                cpu = ru1.ru_utime + ru1.ru_stime - ru0.ru_utime - ru0.ru_stime
                tref = [p["temperature"] for p in ref[1:]]
                row = dict(c=c, dev=devs(prog, tref), ses=ses(prog), ref_ses=ses(ref), wall=cpu,
                           psteps=summ["events"] * MD_N, err=rel_err(prog, tref), se=rel_se(prog), ref_se=rel_se(ref))
                mdrows[(nu, lam)] = row
                table.append(row)
                print(c["name"], "md", row["wall"], row["psteps"], row["err"], file=sys.stderr)
        sel = list(mdrows.values())
        xs = [(r["psteps"], r["psteps"] * r["c"]["nu"]) for r in sel]
        a, b = lsq2(xs, [r["wall"] for r in sel], [1 / r["wall"] ** 2 for r in sel])
        model["cost"]["md"][str(dim)] = {"per_particle_step": a, "per_particle_step_density": b}
        cb = [[curves(mdrows[(nu, lam)], "md") for lam in grid["lambda"]] for nu in grid["volume_fraction"]]
        grid["variants"]["md"] = {"bias": [[x[0] for x in r] for r in cb], "spread": [[x[1] for x in r] for r in cb]}
    model["generated"]["md"] = {"by": "bench/tradeoff.py --md", "date": time.strftime("%Y-%m-%d", time.gmtime()),
                                "particles": MD_N, "replicas": R}
    model = round_sig(model)
    with open(MD_MODEL, "w") as f:
        json.dump(model, f, indent=1)
        f.write("\n")
    with open(os.path.join(DOCDIR, "tradeoff-md.md"), "w") as f:
        f.write("# Soft-sphere MD against ed on the cooling grid (issue 18)\n\n"
                "Generated by `bench/tradeoff.py ENGINE docs --md data/advice-model.json` (in `make bench`), %s.\n"
                "Homogeneous cooling of N = %d particles, %d replicas, to Haff time %g, %d output times, on the\n"
                "advice model's grid; md at its defaults (linear law, max_overlap 0.01 at 4 sqrt(T/m), step t_c/50, no\n"
                "friction), ed (TC below e = 0.8) from the same random placement (no relax: md has none). Error =\n"
                "relative RMS over the output times of T_md/T_ed - 1, next to the standard errors of both ensembles\n"
                "(the relative SE of T, RMS over the output times): an error within about sqrt(md SE^2 + ed SE^2) is\n"
                "no measured bias. Cost = the md process's CPU seconds (user + system, placement included) per\n"
                "particle-step; the fit a + b nu per D is `cost.md` of the model, the bias and spread curves over the\n"
                "Haff time its `md` variant (the same definitions as the other variants: tradeoff.md).\n\n"
                % (time.strftime("%Y-%m-%d", time.gmtime()), MD_N, R, TAU_END, K))
        f.write("| case | md error (rel. RMS of T/T_ed - 1) | md SE | ed SE | md CPU s | particle-steps | s per particle-step |\n"
                "|---|---|---|---|---|---|---|\n")
        for r in table:
            f.write("| %s | %.3g | %.2g | %.2g | %.3g | %.3g | %.3g |\n" % (r["c"]["name"], r["err"], r["se"], r["ref_se"],
                    r["wall"], r["psteps"], r["wall"] / r["psteps"]))
        for dim in (2, 3):
            c = model["cost"]["md"][str(dim)]
            f.write("\nCost fit %dD: %.3g + %.3g nu s per particle-step.\n" % (dim, c["per_particle_step"],
                    c["per_particle_step_density"]))
    sys.exit(0)


# ---- the table ------------------------------------------------------------------------------
# Every row keeps its per-output-time series (dev: T/T_ED - 1, se: its relative SE, ref_ses: the reference's),
# from which the model's growth with the Haff time is fitted.
rows = []
if REFIT:
    saved = json.load(open(REFIT))
    rows, ho_measured = saved["rows"], saved["held"]
    t_start -= saved["seconds"]
for c in ([] if REFIT else cases()):
    ref, refsum = run(case_scene(c, "ed", None))
    tref = [p["temperature"] for p in ref[1:]]
    ref_se = rel_se(ref)
    norm = R * c["t_end"] * c["n"]
    rows.append(dict(case=c["name"], c=c, method="ed", setting="reference (%d replicas)" % R,
                     cost=refsum["wall_seconds"] / norm, err=ref_se, ref_se=ref_se, se=ref_se, warn="",
                     wall=refsum["wall_seconds"], collisions=refsum["collisions"], moves=0,
                     dev=[0.0] * len(tref), ses=ses(ref), ref_ses=ses(ref)))
    print(c["name"], "ed", rows[-1]["cost"], ref_se, file=sys.stderr)
    for method, cr, extra, label in variants(c):
        try:
            prog, summ = run(case_scene(c, method, extra))
        except RuntimeError as ex:
            print("skip", c["name"], method, label, ex, file=sys.stderr)
            continue
        rows.append(dict(case=c["name"], c=c, method=method + "/" + cr, setting=label,
                         cost=summ["wall_seconds"] / norm, err=rel_err(prog, tref), ref_se=ref_se, se=rel_se(prog),
                         warn="yes" if prog[0].get("warning") else "", wall=summ["wall_seconds"],
                         collisions=summ["collisions"], moves=summ["events"],
                         dev=devs(prog, tref), ses=ses(prog), ref_ses=ses(ref)))
        print(c["name"], method, cr, label, rows[-1]["cost"], rows[-1]["err"], file=sys.stderr)


# ---- the model ------------------------------------------------------------------------------
def fit_rms(rowsel, pred):
    r = [pred(x) / x["wall"] - 1 for x in rowsel]
    return math.sqrt(sum(v * v for v in r) / len(r)) if r else float("nan")


cool = [r for r in rows if r["c"]["kind"] == "cooling"]
model = {"format": "granulard-advice-model", "version": 2,
         "generated": {"by": "bench/tradeoff.py%s" % (" --quick" if QUICK else ""),
                       "date": time.strftime("%Y-%m-%d", time.gmtime()),
                       "machine": "%s, %d cores (shared)" % (platform.processor() or platform.machine(), os.cpu_count()),
                       "replicas": R},
         "particles_measured": N, "density_axis": DENSITY_AXIS,
         "cost": {"ed": {}, "dsmc": {}, "hsmc": {}}, "error": {}}
fit_quality = {}
for dim in (2, 3):
    sel = [r for r in cool if r["method"] == "ed" and r["c"]["dim"] == dim]
    xs = [(r["collisions"], r["collisions"] / (r["c"]["nu"] * g_contact(dim, r["c"]["nu"]))) for r in sel]
    a, b = lsq2(xs, [r["wall"] for r in sel], [1 / r["wall"] ** 2 for r in sel])
    model["cost"]["ed"][str(dim)] = {"per_collision": a, "per_collision_dilute": b}
    fit_quality[("ed", dim)] = fit_rms(sel, lambda r: r["collisions"] * (a + b / (r["c"]["nu"] * g_contact(dim, r["c"]["nu"]))))
    for m in ("dsmc", "hsmc"):
        sel = [r for r in cool if r["method"].startswith(m) and r["c"]["dim"] == dim and r["setting"].startswith("auto")]
        xs = [(r["moves"], r["collisions"]) for r in sel]
        pm, pc = lsq2(xs, [r["wall"] for r in sel], [1 / r["wall"] ** 2 for r in sel])
        model["cost"][m][str(dim)] = {"per_move": pm, "per_collision": pc}
        fit_quality[(m, dim)] = fit_rms(sel, lambda r: pm * r["moves"] + pc * r["collisions"])
    nus = sorted({r["c"]["nu"] for r in cool if r["c"]["dim"] == dim})
    lams = sorted({round(1 - r["c"]["e"] ** 2, 12) for r in cool if r["c"]["dim"] == dim})
    grid = {"volume_fraction": nus, "lambda": lams, "haff_time": [TAU_END * (k + 1) / K for k in range(K)],
            "variants": {}, "clustering": {}}
    for var in ("ed", "dsmc/none", "dsmc/enskog", "hsmc/cba"):
        bias, spread = [], []
        for nu in nus:
            brow, srow = [], []
            for lam in lams:
                pts = [r for r in cool if r["c"]["dim"] == dim and r["c"]["nu"] == nu and
                       abs(1 - r["c"]["e"] ** 2 - lam) < 1e-9 and r["method"] == var and
                       (var == "ed" or r["setting"] == DEFAULT)]
                if not pts:
                    raise SystemExit("no %s point at D=%d nu=%g lambda=%g" % (var, dim, nu, lam))
                b, sp = curves(pts[0], var)
                brow.append(b)
                srow.append(sp)
            bias.append(brow)
            spread.append(srow)
        grid["variants"][var] = {"bias": bias, "spread": spread}
        clu = [r for r in rows if r["c"]["kind"] == "clustering" and r["c"]["dim"] == dim and r["method"] == var and
               r["setting"] == DEFAULT and var != "ed"]
        if clu:
            p = clu[0]
            grid["clustering"][var] = math.sqrt(max(0.0, p["err"] ** 2 - p["se"] ** 2 - p["ref_se"] ** 2))
    model["error"][str(dim)] = grid


model = round_sig(model)

# ---- held-out check: scenes the model was not fitted on ----------------------------------------
HO_VARIANTS = (("ed", None), ("dsmc", "none"), ("dsmc", "enskog"), ("hsmc", "cba"))


def ho_cases():
    return [dict(name="held-out 2D nu=0.2 e=0.7", dim=2, nu=0.2, e=0.7, n=N_HELD,
                 t_end=cooling_t_end(2, 0.2, 0.7, 1.5), kind="held"),
            dict(name="held-out 2D nu=0.1 e=0.8 (short: tau 0.5)", dim=2, nu=0.1, e=0.8, n=N_HELD,
                 t_end=cooling_t_end(2, 0.1, 0.8, 0.5), kind="held"),
            dict(name="held-out 3D nu=0.15 e=0.8", dim=3, nu=0.15, e=0.8, n=N_HELD,
                 t_end=cooling_t_end(3, 0.15, 0.8, 1.0), kind="held"),
            dict(name="held-out 3D nu=0.15 e=0.8 (stop at 15 coll/particle)", dim=3, nu=0.15, e=0.8, n=N_HELD,
                 t_end=cooling_t_end(3, 0.15, 0.8, math.exp(15 * 0.36 / 6) - 1), cpp_end=15.0, kind="held")]


if not REFIT:              # the measured side of the held-out check (kept with --rows)
    ho_measured = []
    for c in ho_cases():
        ref, refsum = run(case_scene(c, "ed", None))
        tref = None if "cpp_end" in c else [p["temperature"] for p in ref[1:]]   # stops differ per method
        for m, cr in HO_VARIANTS:
            if m == "ed":
                prog, summ, err = ref, refsum, rel_se(ref)
            else:
                prog, summ = run(case_scene(c, m, {"correction": cr}))
                err = rel_err(prog, tref) if tref is not None else float("nan")
            ho_measured.append(dict(case=c["name"], variant=m if m == "ed" else m + "/" + cr, cost=summ["wall_seconds"],
                                    coll=summ["collisions"], err=err, ref_se=rel_se(ref)))
            print("held", ho_measured[-1], file=sys.stderr)
if ROWS:
    with open(ROWS, "w") as f:
        json.dump({"rows": rows, "held": ho_measured, "seconds": time.time() - t_start}, f)

held = []
if MODEL:
    with open(MODEL, "w") as f:
        json.dump(model, f, indent=1)
        f.write("\n")
    for c in ho_cases():
        est = {e["variant"]: e for e in advise(case_scene(c, "ed", None))["estimates"]}
        base = {e["variant"]: e for e in advise(case_scene(c, "ed", None), BASELINE)["estimates"]} if BASELINE else {}
        for h in [x for x in ho_measured if x["case"] == c["name"]]:
            e = est[h["variant"]]
            relax_coll = R * c["n"] * 10 / 2
            b = base.get(h["variant"])
            held.append(dict(h, method=h["variant"], pred_cost=e["cpu_seconds"] - e["setup_cpu_seconds"],
                             pred_coll=e["collisions"] - relax_coll, pred_err=e["error"]["temperature"],
                             base_err=b["error"]["temperature"] if b else None,
                             extrapolated=e["extrapolated"]))
            print("held", held[-1], file=sys.stderr)

# ---- the document -----------------------------------------------------------------------------
md = os.path.join(DOCDIR, "tradeoff.md")
png = os.path.join(DOCDIR, "tradeoff.png")
cmd = "make bench (bench/tradeoff.py ENGINE DOCDIR --model data/advice-model.json%s%s)" % (
    " --quick" if QUICK else "", " --baseline OLD_ENGINE" if BASELINE else "")
with open(md, "w") as f:
    f.write("# The trade: cost against accuracy, DSMC/HSMC vs event-driven MD\n\n")
    f.write("Written by `%s`; numbers from the last run (%.0f s). Do not edit by hand.\n\n" % (cmd, time.time() - t_start))
    f.write("- Machine: %s, %d cores, shared with other jobs; one engine run at a time, one rank.\n" %
            (platform.processor() or platform.machine(), os.cpu_count()))
    f.write("- Date: %s.\n" % time.strftime("%Y-%m-%d", time.gmtime()))
    f.write("- Homogeneous cooling from an equilibrated elastic state (10 collisions per particle), periodic box, diameter 1,\n"
            "  mass 1, T0 = 1, to Haff time tau = %g (T/T0 = 1/9 if homogeneous); N = %d. Clustering: 2D, nu = 0.25,\n"
            "  e = 0.8, to tau = 10 (clusters form; Haff's law no longer holds).\n" % (TAU_END, N))
    f.write("- Reference: event-driven MD (exact for hard spheres), %d replicas; `ref SE` is its relative standard error\n"
            "  of T (RMS over the output times): an MC error at or below it is not resolved.\n" % R)
    f.write("- Error: relative RMS of T_MC(t)/T_ED(t) - 1 over %d output times, each MC point also %d replicas.\n" % (K, R))
    f.write("- Cost: CPU seconds per unit simulated time per particle, from the engine's own `wall_seconds` of the\n"
            "  production run (process start, set-up and the elastic pre-run excluded), summed over the replicas.\n"
            "  `warn`: the engine's validity warning fired.\n")
    f.write("- dsmc is shown with correction `none` (its default) and `enskog`; hsmc with `cba` (its default).\n\n")
    f.write("![error vs cost](tradeoff.png)\n\n")
    f.write("| case | method | setting | cost (s per time per particle) | error (rel. RMS) | ref SE | warn |\n|---|---|---|---|---|---|---|\n")
    for r in rows:
        f.write("| %s | %s | %s | %.3g | %.3g | %.2g | %s |\n" % (r["case"], r["method"], r["setting"], r["cost"], r["err"],
                                                           r["ref_se"], r["warn"]))
    f.write("\n## The advice model\n\n")
    f.write("Fitted from the table above and written to `data/advice-model.json`, which the build embeds in\n"
            "`granular-engine` and `granulard` (`granular-engine advise`, `POST /api/v1/advice`, `\"method\": \"auto\"`).\n"
            "Form (engine/advice.h):\n\n"
            "- Work: production collisions per particle from Haff's law for the gas each method simulates,\n"
            "  `cpp = (2D/lambda) ln(1 + lambda f0 t / (2D))` with `lambda = 1 - e^2` and `f0` the Enskog collision frequency\n"
            "  (chi = g(sigma); chi = 1 for dsmc/none), or the stop condition; plus the elastic pre-run. MC steps = cpp / 0.2\n"
            "  (+1 per output time); moves = N x steps.\n"
            "- Cost: ed `collisions x (a + b / (nu chi))` (cell crossings per collision grow with the mean free path);\n"
            "  dsmc/hsmc `moves x s_move + collisions x s_coll`. Fitted by least squares in relative terms on the cooling rows\n"
            "  (MC: every automatic-cell row, all three step sizes).\n"
            "- Error: `sqrt(bias^2 + spread^2 / (N x replicas))`, bias and spread functions of (volume fraction,\n"
            "  lambda, Haff time tau reached by the run), from the cooling cases at default settings: at each grid point\n"
            "  and output time tau_k the error of a run stopping there (RMS over its outputs), bias^2 = error^2 -\n"
            "  SE_MC^2 - SE_ref^2 (made non-decreasing in tau), spread = SE x sqrt(N x replicas). In tau: linear between\n"
            "  the output times, bias linear to 0 at tau = 0 below the first, spread constant there; beyond tau = %g\n"
            "  clamped (and the MC bias at least the clustering case's), `extrapolated`. In (nu, lambda): bilinear in\n"
            "  (chi(nu) - 1, lambda) (chi the contact value: the coordinate the collision rate, and dsmc/none's bias,\n"
            "  follow), clamped outside the grid and `extrapolated`; linear to 0 at lambda = 0. Outside the grid,\n"
            "  beyond Haff time %g, with non-default MC settings, on validity warnings or at N > 10x %d an estimate is\n"
            "  flagged `extrapolated`.\n\n" % (TAU_END, TAU_END, N))
    f.write("| constant | D = 2 | D = 3 | fit: RMS relative residual (2D / 3D) |\n|---|---|---|---|\n")
    cm = model["cost"]
    f.write("| ed a (s per collision) | %.3g | %.3g | %.2f / %.2f |\n" % (cm["ed"]["2"]["per_collision"], cm["ed"]["3"]["per_collision"],
                                                                       fit_quality[("ed", 2)], fit_quality[("ed", 3)]))
    f.write("| ed b (s per collision x nu chi) | %.3g | %.3g | |\n" % (cm["ed"]["2"]["per_collision_dilute"], cm["ed"]["3"]["per_collision_dilute"]))
    for m in ("dsmc", "hsmc"):
        f.write("| %s s_move | %.3g | %.3g | %.2f / %.2f |\n" % (m, cm[m]["2"]["per_move"], cm[m]["3"]["per_move"],
                                                               fit_quality[(m, 2)], fit_quality[(m, 3)]))
        f.write("| %s s_coll | %.3g | %.3g | |\n" % (m, cm[m]["2"]["per_collision"], cm[m]["3"]["per_collision"]))
    f.write("\n| D | variant | bias at tau = %g, %g (rows: nu; columns: lambda) | spread at tau = %g |\n|---|---|---|---|\n"
            % (TAU_END / K, TAU_END, TAU_END))
    for dim in ("2", "3"):
        g = model["error"][dim]
        for var, v in g["variants"].items():
            f.write("| %s | %s | %s; %s | %s |\n" % (dim, var, [[b[0] for b in r] for r in v["bias"]],
                                                   [[b[-1] for b in r] for r in v["bias"]],
                                                   [[b[-1] for b in r] for r in v["spread"]]))
        f.write("| %s | grid | nu = %s, lambda = %s; clustering: %s | |\n" % (dim, g["volume_fraction"], g["lambda"],
                                                                          g["clustering"] or "not measured"))
    if held:
        f.write("\n### Held-out check\n\n"
                "Scenes the model was not fitted on (other volume fraction, restitution and N = %d, %d replicas):\n"
                "`granular-engine advise --model` on the fresh model against the measured run. Cost: production CPU s\n"
                "(the pre-run excluded on both sides); collisions: production, all replicas; error: the MC run against\n"
                "the ED run (which carries its own `ref SE`), for ed its own SE. With a stop after a number of\n"
                "collisions the methods stop at different times, so no time-wise error is measured there.\n\n" % (N_HELD, R))
        bl = BASELINE is not None
        f.write("| case | method | cost predicted | measured | ratio | collisions predicted | measured | error predicted |%s measured | ref SE |\n"
                "|---|---|---|---|---|---|---|---|%s---|---|\n" % (" before |" if bl else "", "---|" if bl else ""))
        for h in held:
            f.write("| %s | %s%s | %.3g | %.3g | %.2f | %.4g | %.4g | %.3g |%s %s | %.2g |\n" % (
                h["case"], h["method"], " (extrapolated)" if h["extrapolated"] else "", h["pred_cost"], h["cost"],
                h["pred_cost"] / h["cost"], h["pred_coll"], h["coll"], h["pred_err"],
                (" %.3g |" % h["base_err"] if h["base_err"] is not None else " - |") if bl else "",
                "-" if h["err"] != h["err"] else "%.3g" % h["err"], h["ref_se"]))
        if bl:
            f.write("\n`before`: the expected error of the previous model (%s), for comparison.\n" % BASELINE_NOTE)

        def summary(key):
            # an MC run is measured against the ED run, which adds the reference's SE: compare like with like
            r = [math.sqrt(h[key] ** 2 + (h["ref_se"] ** 2 if h["method"] != "ed" else 0)) / h["err"]
                 for h in held if h["err"] == h["err"] and h.get(key) is not None]
            g = math.exp(sum(math.log(x) for x in r) / len(r))
            return "geometric mean %.2f, range %.2f-%.2f over %d runs" % (g, min(r), max(r), len(r))
        cr = [h["pred_cost"] / h["cost"] for h in held]
        f.write("\nSummary: cost predicted/measured: geometric mean %.2f, range %.2f-%.2f. Error predicted/measured\n"
                "(MC: sqrt(predicted^2 + ref SE^2), as the measured error carries the reference's noise): %s%s.\n" % (
                    math.exp(sum(math.log(x) for x in cr) / len(cr)), min(cr), max(cr), summary("pred_err"),
                    "; before: " + summary("base_err") if bl else ""))
    bounded = os.path.join(DOCDIR, "tradeoff-bounded.md")   # bench/tradeoff_bounded.py, run before this
    if os.path.exists(bounded):
        f.write("\n" + open(bounded).read())
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
        ax.set_xlabel("cost: CPU s per unit time per particle (production run)")
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
print("wrote", md, MODEL or "", "in %.0f s" % (time.time() - t_start), file=sys.stderr)
