#!/usr/bin/env python3
# Usage: compare_slip.py DATASET_DIR RUN_JSONL (docs/slip.md, "Against the twin").
# Compares tac3d run --json slip estimates with a twin dataset's per-marker truth: the state
# confusion, the slip fraction, mu in gross slip and, at every onset of gross slip, how early
# partial slip was reported.
import json, math, sys, os, collections
ds, run = sys.argv[1], sys.argv[2]
MIN_RUN = 3  # an onset starts a true gross-slip run of at least this many frames
lines = [json.loads(l) for l in open(run) if l.startswith('{')]
def truth(i):
    s = json.load(open(os.path.join(ds, 'steps', '%06d.json' % i)))
    m = s['markers']
    c = m['contact']; sl = m['slip']
    nc = sum(c); ns = sum(1 for a, b in zip(c, sl) if a and b)
    f = s.get('total_force_n') or s.get('force', {}).get('total_n')
    return nc, ns, s, f
conf = collections.Counter(); frac_err = []; mu_err = []; within2 = 0; ngross = 0
rows = []; seq = []  # (index, time, true state, estimated state)
for l in lines:
    if l['initialize_progress'] < 100: continue
    nc, ns, s, f = truth(l['index'])
    ts = 'none' if nc < 4 else ('stick' if ns / nc < 0.1 else ('gross_slip' if ns / nc > 0.9 else 'partial_slip'))
    conf[(ts, l['slip_state'])] += 1
    seq.append((l['index'], l['timestamp_s'], ts, l['slip_state']))
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
true_gross = sum(v for k, v in conf.items() if k[0] == 'gross_slip')
print('true gross slip read gross slip: %d of %d' % (conf[('gross_slip', 'gross_slip')], true_gross))
if frac_err:
    frac_err.sort()
    print('slip fraction abs error: mean %.3f median %.3f p90 %.3f (n=%d)' % (sum(frac_err)/len(frac_err), frac_err[len(frac_err)//2], frac_err[int(0.9*len(frac_err))], len(frac_err)))
if mu_err:
    a = sorted(abs(e) for e in mu_err)
    print('gross slip mu vs true |Ft|/Fn: n=%d mean err %+.4f, mean abs %.4f, p90 abs %.4f, max abs %.4f, over 0.05: %d, within 2 sigma %.2f' % (len(mu_err), sum(mu_err)/len(mu_err), sum(a)/len(a), a[int(0.9*len(a))], a[-1], sum(e > 0.05 for e in a), within2/ngross))
    for r in rows[::max(1, len(rows)//8)]: print('  step %d true %.3f est %.3f +- %.3f' % r)
# Onsets: the first frame of a true gross-slip run of at least MIN_RUN frames. The warning is the
# run of consecutive partial-slip reports that ends just before the true onset or the
# estimator's first gross slip since the contact began, whichever comes first; its lead is
# measured from its first frame to the true onset.
print('onsets of gross slip (MIN_RUN %d): true onset, estimated gross slip, first partial slip of the run before it, lead to the true onset' % MIN_RUN)
leads = []
for j in range(1, len(seq)):
    if seq[j][2] != 'gross_slip' or seq[j - 1][2] == 'gross_slip': continue
    if any(seq[m][2] != 'gross_slip' for m in range(j, min(len(seq), j + MIN_RUN))): continue
    a = j
    while a > 0 and seq[a - 1][2] != 'none': a -= 1
    g = next((m for m in range(a, len(seq)) if seq[m][3] == 'gross_slip'), None)
    p = None
    m = min(j, g if g is not None else j) - 1
    while m >= a and seq[m][3] == 'partial_slip': p = m; m -= 1
    if p is None or p >= j:
        print('  step %d: gross slip read at %s, NO partial slip before the onset' % (seq[j][0], seq[g][0] if g is not None else 'never'))
        leads.append(None); continue
    lead_s = seq[j][1] - seq[p][1]
    leads.append(lead_s)
    print('  step %d: gross slip read at step %s, partial slip from step %d: lead %d frames, %.0f ms' % (seq[j][0], seq[g][0] if g is not None else 'never', seq[p][0], seq[j][0] - seq[p][0], 1000 * lead_s))
ok = [x for x in leads if x is not None]
print('onsets warned %d of %d; lead min %.0f ms' % (len(ok), len(leads), 1000 * min(ok) if ok else float('nan')))
