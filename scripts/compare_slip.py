#!/usr/bin/env python3
# Usage: compare_slip.py DATASET_DIR RUN_JSONL (docs/slip.md, "Against the twin").
# Compares tac3d run --json slip estimates with a twin dataset's per-marker truth.
import json, math, sys, os, collections
ds, run = sys.argv[1], sys.argv[2]
lines = [json.loads(l) for l in open(run) if l.startswith('{')]
def truth(i):
    s = json.load(open(os.path.join(ds, 'steps', '%06d.json' % i)))
    m = s['markers']
    c = m['contact']; sl = m['slip']
    nc = sum(c); ns = sum(1 for a, b in zip(c, sl) if a and b)
    f = s.get('total_force_n') or s.get('force', {}).get('total_n')
    return nc, ns, s, f
conf = collections.Counter(); frac_err = []; mu_err = []; within2 = 0; ngross = 0
rows = []
for l in lines:
    if l['initialize_progress'] < 100: continue
    nc, ns, s, f = truth(l['index'])
    ts = 'none' if nc < 4 else ('stick' if ns / nc < 0.1 else ('gross_slip' if ns / nc > 0.9 else 'partial_slip'))
    conf[(ts, l['slip_state'])] += 1
    if nc >= 4 and l['slip_fraction'] is not None:
        frac_err.append(abs(l['slip_fraction'] - ns / nc))
    if l['slip_state'] == 'gross_slip' and ts == 'gross_slip' and f is not None:
        true_mu = math.hypot(f[0], f[1]) / -f[2]
        mu_err.append(l['friction'] - true_mu); ngross += 1
        within2 += abs(l['friction'] - true_mu) < 2 * l['friction_sigma']
        rows.append((l['index'], true_mu, l['friction'], l['friction_sigma']))
print('frames compared', sum(conf.values()))
print('state confusion (truth -> estimate):')
for k, v in sorted(conf.items()): print('  %-13s -> %-13s %d' % (k[0], k[1], v))
agree = sum(v for k, v in conf.items() if k[0] == k[1])
print('state agreement %.3f' % (agree / max(1, sum(conf.values()))))
if frac_err:
    frac_err.sort()
    print('slip fraction abs error: mean %.3f median %.3f p90 %.3f (n=%d)' % (sum(frac_err)/len(frac_err), frac_err[len(frac_err)//2], frac_err[int(0.9*len(frac_err))], len(frac_err)))
if mu_err:
    a = sorted(abs(e) for e in mu_err)
    print('gross slip mu vs true |Ft|/Fn: n=%d mean err %+.4f, mean abs %.4f, p90 abs %.4f, within 2 sigma %.2f' % (len(mu_err), sum(mu_err)/len(mu_err), sum(a)/len(a), a[int(0.9*len(a))], within2/ngross))
    for r in rows[::max(1, len(rows)//8)]: print('  step %d true %.3f est %.3f +- %.3f' % r)
