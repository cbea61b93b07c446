import sys, time, re, os
src = open(sys.argv[1]).read()
cells = re.split(r"^# %%.*$", src, flags=re.M)
g = {"__name__": "__main__"}
os.chdir(os.path.dirname(os.path.abspath(sys.argv[1])))
import matplotlib; matplotlib.use("Agg")
t00 = time.perf_counter()
for i, c in enumerate(cells):
    if not c.strip() or all(l.startswith("#") or not l.strip() for l in c.splitlines()):
        continue
    t0 = time.perf_counter()
    import contextlib, io
    with contextlib.redirect_stdout(io.StringIO()):
        exec(compile(c, f"cell{i}", "exec"), g)
    print(f"cell {i:2d} {time.perf_counter()-t0:7.1f} s  {c.strip().splitlines()[0][:70]}", flush=True)
print("total", time.perf_counter() - t00)
