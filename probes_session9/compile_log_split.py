import re, collections
rows = [l.rstrip("\n").split("\t", 3) for l in open("/tmp/complog/suite.log") if l.count("\t") >= 3]
pids_by_mod = collections.defaultdict(set)
for pid, t, who, msg in rows:
    if who.startswith("sub:"): continue
    mod = who.split("::")[0]
    pids_by_mod[mod].add(pid)
# setup durations from pytest per module
setups = collections.defaultdict(list)
for line in open("/tmp/complog/suite.out"):
    m = re.match(r"^([\d.]+)s setup\s+(\S+)", line)
    if m and float(m[1]) > 1.0:
        setups[m[2].split("::")[0]].append((float(m[1]), m[2].split("::")[1][:60]))
for mod in sorted(setups, key=lambda k: -sum(x for x, _ in setups[k])):
    print(f"{mod:35s} workers(pids w/ in-process jax)={len(pids_by_mod.get(mod, ()))} setups>1s: {[(round(x,1), n) for x, n in sorted(setups[mod], reverse=True)[:4]]}")
