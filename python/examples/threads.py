"""Measures whether renders called from Python threads run in parallel
(the GIL is released): wall time of one render against two at once from
two threads, and the process CPU time over the wall time.

    python python/examples/threads.py [SCENE] [SPP]

Prints one JSON line. With the GIL held, two renders would take twice as
long as one; released, on 2 cores they take about as long as one and the
process uses ~2 CPU-seconds per second.
"""

import json
import os
import sys
import threading
import time

import gloam

scene_path = sys.argv[1] if len(sys.argv) > 1 else "sims/office-room/scene.toml"
spp = int(sys.argv[2]) if len(sys.argv) > 2 else 4
scene = gloam.Scene.load(scene_path)
kw = dict(spp=spp, seed=1, threads=1, settings={"indirect": "off"})


def timed(n):
    """Wall and CPU seconds of n single-threaded renders started at once."""
    threads = [threading.Thread(target=gloam.render, args=(scene,), kwargs=kw) for _ in range(n)]
    w0, c0 = time.perf_counter(), time.process_time()
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    return time.perf_counter() - w0, time.process_time() - c0


def busy_threads(step_s=0.5):
    """Per 0.5 s window while two renders run from two Python threads: how
    many threads of the process got CPU time (> 0.01 s, Linux
    /proc/self/task/*/schedstat). Each render works on its own worker
    thread; with the GIL held during a render only one could run, so two
    busy threads in a window show it released, however loaded the machine."""
    threads = [threading.Thread(target=gloam.render, args=(scene,), kwargs=kw) for _ in range(2)]

    def sample():
        out = {}
        for tid in os.listdir("/proc/self/task"):
            try:
                with open(f"/proc/self/task/{tid}/schedstat") as f:
                    out[tid] = int(f.read().split()[0]) / 1e9
            except OSError:
                pass
        return out

    for t in threads:
        t.start()
    counts, a = [], sample()
    while all(t.is_alive() for t in threads):
        time.sleep(step_s)
        b = sample()
        counts.append(sum(1 for k in b if b[k] - a.get(k, 0.0) > 0.01))
        a = b
    for t in threads:
        t.join()
    return counts


timed(1)  # warm up (page cache, allocator)
one_wall, one_cpu = timed(1)
two_wall, two_cpu = timed(2)
counts = busy_threads()
load = os.getloadavg()[0]
print(json.dumps({
    "scene": scene_path,
    "spp": spp,
    "cores": os.cpu_count(),
    "one_render_wall_s": round(one_wall, 3),
    "two_concurrent_renders_wall_s": round(two_wall, 3),
    "slowdown_two_vs_one": round(two_wall / one_wall, 3),
    "cpu_per_wall_two": round(two_cpu / two_wall, 2),
    "speedup_vs_serial": round(2 * one_wall / two_wall, 3),
    "busy_threads_per_half_second": counts,
    "windows_with_two_or_more_busy": f"{sum(c >= 2 for c in counts)}/{len(counts)}",
    "load_average_1min": round(load, 2),
}))
