import re, sys, collections
rows = [l.rstrip("\n").split("\t", 3) for l in open(sys.argv[1]) if l.count("\t") >= 3]
T = re.compile(r"Finished tracing (?:\+ transforming )?(.+?) for (?:jit|pjit) in ([\d.e-]+) sec")
L = re.compile(r"Finished jaxpr to MLIR module conversion jit\((.+?)\) in ([\d.e-]+) sec")
C = re.compile(r"Finished XLA compilation of jit\((.+?)\) in ([\d.e-]+) sec")
MISS = re.compile(r"CACHE MISS for '(.+?)' with key '(.+?)'")
HIT = re.compile(r"cache hit for '(.+?)'", re.I)
def testname(w):
    w = w.split(" (")[0]
    return w
per = collections.defaultdict(lambda: collections.Counter())
last = {}
keys = collections.Counter(); keytime = {}; keytests = collections.defaultdict(set)
big_miss = []
for pid, t, who, msg in rows:
    tn = testname(who)
    if m := T.search(msg): per[tn]["trace"] += float(m[2])
    elif m := L.search(msg): per[tn]["lower"] += float(m[2])
    elif m := MISS.search(msg): last[pid] = ("miss", m[2])
    elif m := HIT.search(msg): last[pid] = ("hit", None)
    elif m := C.search(msg):
        kind, key = last.pop(pid, ("nocache", None))
        d = float(m[2])
        per[tn]["compile_" + kind] += d
        if kind == "miss":
            keys[key] += 1; keytime[key] = (m[1], d); keytests[key].add(tn)
            if d > 2: big_miss.append((d, m[1], tn))
tot = collections.Counter()
for tn, c in per.items(): tot.update(c)
print("TOTAL", {k: round(v) for k, v in tot.items()})
print("keys missed more than once:", sum(1 for k, v in keys.items() if v > 1), "time", round(sum(keytime[k][1]*(v-1) for k, v in keys.items() if v > 1)))
for k, v in sorted(keys.items(), key=lambda kv: -keytime[kv[0]][1]*(kv[1]-1))[:10]:
    if v > 1: print("  dup", v, keytime[k], sorted(keytests[k])[:3])
fileagg = collections.defaultdict(collections.Counter)
for tn, c in per.items(): fileagg[tn.split("::")[0]].update(c)
print("\nper file: trace lower compile_miss compile_hit nocache")
for f, c in sorted(fileagg.items(), key=lambda kv: -sum(kv[1].values())):
    print(f"{f:45s} {c['trace']:7.1f} {c['lower']:6.1f} {c['compile_miss']:7.1f} {c['compile_hit']:6.1f} {c['compile_nocache']:6.1f}")
print("\ntop tests by trace+lower+compile")
for tn, c in sorted(per.items(), key=lambda kv: -sum(kv[1].values()))[:40]:
    print(f"{sum(c.values()):6.1f} tr {c['trace']:5.1f} lo {c['lower']:4.1f} miss {c['compile_miss']:5.1f} hit {c['compile_hit']:4.1f} nc {c['compile_nocache']:5.1f}  {tn[:110]}")
print("\nmisses by function name (count, total s)")
byname = collections.defaultdict(lambda: [0, 0.0])
for k, (name, d) in keytime.items():
    byname[name][0] += keys[k]; byname[name][1] += d * keys[k]
for name, (n, s) in sorted(byname.items(), key=lambda kv: -kv[1][1])[:25]:
    print(f"  {name:40s} {n:5d} {s:7.1f}")
b = collections.Counter(); bs = collections.Counter()
for k, (name, d) in keytime.items():
    bucket = "<0.5" if d < .5 else "0.5-2" if d < 2 else "2-5" if d < 5 else "5-10" if d < 10 else ">10"
    b[bucket] += keys[k]; bs[bucket] += d * keys[k]
print({k: (b[k], round(bs[k])) for k in b})
