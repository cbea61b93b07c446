import re, sys, collections
rows = [l.rstrip("\n").split("\t", 3) for l in open(sys.argv[1]) if l.count("\t") >= 3]
C = re.compile(r"Finished XLA compilation of jit\((.+?)\) in ([\d.e-]+) sec")
MISS = re.compile(r"CACHE MISS for '(.+?)' with key '(.+?)'")
HIT = re.compile(r"cache hit for '(.+?)'", re.I)
last = {}
miss = collections.defaultdict(list)  # key -> [(time, dur, test, pid, fn)]
for pid, t, who, msg in rows:
    tn = who.split(" (")[0]
    if m := MISS.search(msg): last[pid] = m[2]
    elif m := C.search(msg):
        key = last.pop(pid, None)
        if key: miss[key].append((float(t), float(m[2]), tn, pid, m[1]))
dup = [(sum(d for _, d, *_ in v[1:]), k, v) for k, v in miss.items() if len(v) > 1]
dup.sort(reverse=True)
print("duplicate compile time total", round(sum(d for d, *_ in dup)), "over", len(dup), "keys")
pairs = collections.Counter()
for d, k, v in dup:
    tests = tuple(sorted({x[2].split("::")[0] + "::" + x[2].split("::")[1][:50] if "::" in x[2] else x[2][:60] for x in v}))
    pairs[tests] += d
for tests, d in pairs.most_common(40):
    print(f"{d:6.1f}", " | ".join(tests))
