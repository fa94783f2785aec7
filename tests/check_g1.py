# g(r) = 1 beyond two diameters (shared by tests/obswalls_test.sh and tests/obsopen_test.sh): usage
#   check_g1.py OUTDIR LABEL
# reads OUTDIR/observables.jsonl; per bin of the pair_correlation curves from r = 2 diameters on, the mean over
# the snapshots after the first and its standard error (the snapshots must be independent samples: the
# caller's comment says why they are); chi^2 of the bins against 1 below the 99.9% quantile of chi^2 with as
# many degrees of freedom as bins (Wilson-Hilferty; 39.25 for 16). Prints one "ok - ..." or "not ok - ..." line.
import json, math, sys
out, what = sys.argv[1], sys.argv[2]
cur = [json.loads(l) for l in open(out + '/observables.jsonl')]
gs = [c['tables'][0] for c in cur if c['name'] == 'pair_correlation' and c['sample'] > 0]
S = len(gs)
chi, k, worst, zmax = 0.0, 0, None, -1.0
for j, r in enumerate(gs[0]['centres']):
    if gs[0]['edges'][j] < 2.0:
        continue
    v = [t['columns']['g'][j] for t in gs]
    m = sum(v) / S
    se = math.sqrt(sum((x - m) ** 2 for x in v) / (S - 1) / S)
    z = abs(m - 1) / se
    chi += z * z
    k += 1
    if z > zmax:
        worst, zmax = (r, m, se), z
q = k * (1 - 2 / (9 * k) + 3.0902 * math.sqrt(2 / (9 * k))) ** 3
print('%s - %s: g(r) = 1 over r in [2, %g) diameters: chi^2 = %.1f for %d bins (< %.2f), furthest g(%.2f) = '
      '%.4f +- %.4f over %d snapshots' % ('ok' if k >= 8 and chi < q else 'not ok', what, gs[0]['edges'][-1], chi,
      k, q, worst[0], worst[1], worst[2], S))
