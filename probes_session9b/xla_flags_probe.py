import json, os, subprocess, sys, tempfile
sys.path.insert(0, str(__import__("pathlib").Path(__file__).resolve().parents[1] / "benchmarks"))
import compile_time as ct
configs = {
    "base(emitters off)": "--xla_cpu_use_fusion_emitters=false",
    "+no_expensive": "--xla_cpu_use_fusion_emitters=false --xla_llvm_disable_expensive_passes=true",
    "+opt1": "--xla_cpu_use_fusion_emitters=false --xla_backend_optimization_level=1",
}
work = sys.argv[1:] or ["showcase", "gradient"]
for rep in range(1):
    for name, flags in configs.items():
        with tempfile.TemporaryDirectory() as cache:
            env = ct.child_env(flags, cache)
            env["XLA_FLAGS"] = flags
            r = subprocess.run(["taskset", "-c", "0", sys.executable, "-c", ct.CHILD, *work], env=env, capture_output=True, text=True)
            if r.returncode:
                print(name, "FAILED", r.stderr[-500:]); continue
            out = json.loads(r.stdout.strip().splitlines()[-1])
            print(name, {k: (round(v["first"], 2), round(v["warm"], 3), v["values"][:2]) for k, v in out.items()}, flush=True)
