# Benchmark of the Live per-frame path next to Blender's Laplacian Deform
# modifier driven by a Hook modifier: same mesh, same anchors, same empty motion.
#
#   blender --background --factory-startup -noaudio --python-exit-code 1 \
#       --python bench/blender/bench_live.py -- [--addon-dir BUILD/addon] \
#       [--sizes 10000,50000,200000] [--frames 30] [--iterations 2] [--lap-budget 60] [--output DIR] \
#       [--volumes infill,none]
#
# --addon-dir: the folder holding the staged arap_deform package (BUILD/addon);
# without it the add-on is enabled from BLENDER_USER_SCRIPTS.
# Mesh: an open tube (quads) of about N vertices, radius 0.5, height 4. Anchors:
# the bottom fifth (fixed) and the top 5 % (handle, following an Empty that
# moves sideways up to 0.3 h). Per frame, both are timed from after the empty
# moved until the deformed mesh is up to date:
#   ours:    LiveSession.step() (read empties, warm-started solve, write) + view_layer.update()
#   Blender: view_layer.update(), which evaluates Hook + Laplacian Deform
# Settling (--settle-sizes): the same tube with the add-on's default Live settings
# (quasi-Newton, 16 ms frame budget): the empty is dragged over 10 updates, then
# left alone; measured from its last move until step(force=False) returns None
# (settled): updates, CPU ms (time.thread_time) and wall ms of those updates,
# the distance to the converged pose, and the CPU of an idle update.
# --volumes: the Volume settings measured in turn, in one run (ratios to the first).
# Not part of ctest (its name is not test_*.py). Writes blender_live.md / .json.
import argparse
import json
import os
import statistics
import sys
import time

import bpy
import numpy as np
from mathutils import Matrix, Vector

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)   # tube_scene, bench_addon
import bench_addon as U  # noqa: E402
from tube_scene import add_group, laplacian_with_hook, make_tube, move, offsets  # noqa: E402


def parse_args():
    argv = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []
    p = argparse.ArgumentParser(prog="bench_live.py")
    p.add_argument("--addon-dir", default="")
    p.add_argument("--sizes", default="10000,50000,200000")
    p.add_argument("--frames", type=int, default=30)
    p.add_argument("--iterations", type=int, default=2, help="our Live iterations and Laplacian Deform's")
    p.add_argument("--lap-budget", type=float, default=60.0,
                   help="seconds of Laplacian Deform frames per size; it stops after that (3 frames at least)")
    p.add_argument("--settle-sizes", default="10000,50000,250000")
    p.add_argument("--output", default="results")
    p.add_argument("--volumes", default="infill", help="Volume settings (native names), measured in turn")
    return p.parse_args(argv)




def posed_tube(api, name, vertices, volume):
    """The tube with its ARAP set-up: bottom fifth fixed, top 5 % on an Empty at the top centre, Volume `volume`."""
    obj, fixed, top, h = make_tube(name + "Tube", vertices)
    add_group(obj, "fixed", fixed)
    add_group(obj, "top", top)
    start = Vector((0.0, 0.0, h))
    empty = U.add_empty(name + "Handle", Matrix.Translation(start))
    bpy.context.view_layer.update()
    api.set_fixed(obj, "fixed")
    api.add_handle(obj, "top", empty)
    obj.arap.volume = volume.upper()
    return obj, empty, start, h


def bench_ours(api, vertices, frames, iterations, volume):
    obj, empty, start, h = posed_tube(api, "Arap", vertices, volume)
    t = time.perf_counter()
    session = api.start_session(obj, bpy.context.scene, max_iterations=iterations)
    bind_ms = (time.perf_counter() - t) * 1e3
    wall, solve = [], []
    for k, dx in enumerate([0.0] + offsets(frames, h)):  # frame 0 is a warm-up
        move(empty, start, dx)
        t = time.perf_counter()
        stats = session.step()
        bpy.context.view_layer.update()
        if k:
            wall.append((time.perf_counter() - t) * 1e3)
            solve.append(stats.solve_ms)
    session.finish()
    return {"vertices": len(obj.data.vertices), "bind_ms": bind_ms, "frame_ms": wall, "solve_ms": solve,
            "volume": volume}


def bench_settle(api, vertices, volume, drag_updates=10, timer_interval_ms=1000.0 / 30.0):
    obj, empty, start, h = posed_tube(api, "Settle", vertices, volume)
    session = api.start_session(obj, bpy.context.scene)  # the object's (default) Live settings
    session.step()
    while session.step(force=False) is not None:  # settle at rest first
        pass
    for k in range(drag_updates):  # a drag: the empty moves before every update
        move(empty, start, 0.25 * h * (k + 1) / drag_updates)
        session.step(force=False)
        bpy.context.view_layer.update()
    cpu0, wall0 = time.thread_time(), time.perf_counter()
    updates, update_wall = 0, []
    while True:
        t = time.perf_counter()
        stats = session.step(force=False)
        if stats is None:
            break
        bpy.context.view_layer.update()
        update_wall.append((time.perf_counter() - t) * 1e3)
        updates += 1
    settle_cpu = (time.thread_time() - cpu0) * 1e3
    settle_wall = (time.perf_counter() - wall0) * 1e3
    # In the viewport one update runs per timer tick: the wall time a user sees.
    viewport_ms = sum(max(w, timer_interval_ms) for w in update_wall)
    cpu0 = time.thread_time()
    idle_updates = 300
    for _ in range(idle_updates):
        assert session.step(force=False) is None
    idle_cpu_ms = (time.thread_time() - cpu0) * 1e3 / idle_updates
    # The settled pose against the converged one from the same start (the dragged path can
    # end in another local minimum than a cold solve: ARAP is not convex).
    live = session.positions().reshape(-1, 3).astype(np.float64).copy()
    solver = session.solver
    solver.time_budget_ms, solver.tolerance, solver.max_iterations = 0.0, 1e-10, 5000
    solver.solve(session.targets)
    gap = float(np.abs(solver.positions() - live).max())
    session.cancel()
    return {"vertices": len(obj.data.vertices), "updates": updates, "cpu_ms": settle_cpu, "wall_ms": settle_wall,
            "viewport_ms_at_30hz": viewport_ms, "idle_update_cpu_ms": idle_cpu_ms,
            "idle_cpu_percent_at_30hz": 100.0 * idle_cpu_ms / timer_interval_ms,
            "max_distance_to_converged": gap, "height": h,
            "frame_budget_ms": obj.arap.live_frame_ms, "method": obj.arap.method, "volume": volume}


def bench_laplacian(vertices, frames, iterations, budget_s):
    obj, fixed, top, h = make_tube("LapTube", vertices)
    start = Vector((0.0, 0.0, h))
    empty = U.add_empty("LapHandle", Matrix.Translation(start))
    bind_ms = laplacian_with_hook(obj, fixed, top, empty, start, iterations)
    wall = []
    path = offsets(frames, h)
    for k, dx in enumerate([0.0] + path):
        move(empty, start, dx)
        t = time.perf_counter()
        bpy.context.view_layer.update()
        if k:
            wall.append((time.perf_counter() - t) * 1e3)
        if len(wall) >= 3 and sum(wall) > 1e3 * budget_s:
            break
    last_dx = ([0.0] + path)[k]
    # sanity: the evaluated top ring follows the empty
    ev = obj.evaluated_get(bpy.context.evaluated_depsgraph_get()).to_mesh()
    co = np.empty(len(ev.vertices) * 3, np.float32)
    ev.vertices.foreach_get("co", co)
    moved = float(co.reshape(-1, 3)[top, 0].mean())
    obj.evaluated_get(bpy.context.evaluated_depsgraph_get()).to_mesh_clear()
    return {"vertices": len(obj.data.vertices), "bind_ms": bind_ms, "frame_ms": wall,
            "top_dx": moved, "expected_top_dx": last_dx}


def summary(ms):
    q = statistics.quantiles(ms, n=4) if len(ms) > 1 else [ms[0]] * 3
    return {"median": statistics.median(ms), "p25": q[0], "p75": q[2], "min": min(ms), "max": max(ms)}


def main():
    args = parse_args()
    U.load_addon(args.addon_dir)
    api = U.addon("api")
    volumes = [v for v in args.volumes.split(",") if v]
    rows = []
    for n, volume in [(int(x), v) for x in args.sizes.split(",") if x for v in volumes]:
        U.clear_scene()
        ours = bench_ours(api, n, args.frames, args.iterations, volume)
        U.clear_scene()
        lap = bench_laplacian(n, args.frames, args.iterations, args.lap_budget)
        U.clear_scene()
        row = {"target_vertices": n, "ours": ours, "laplacian": lap,
               "ours_frame": summary(ours["frame_ms"]), "ours_solve": summary(ours["solve_ms"]),
               "laplacian_frame": summary(lap["frame_ms"])}
        row["ratio"] = row["ours_frame"]["median"] / row["laplacian_frame"]["median"]
        rows.append(row)
        print("%7d vertices, %s: ours bind %.1f ms, frame %.2f ms (solve %.2f) | Laplacian Deform bind %.1f ms, "
              "frame %.2f ms | ratio %.2f" % (ours["vertices"], volume, ours["bind_ms"], row["ours_frame"]["median"],
                                             row["ours_solve"]["median"], lap["bind_ms"],
                                             row["laplacian_frame"]["median"], row["ratio"]), flush=True)

    settle = []
    for n, volume in [(int(x), v) for x in args.settle_sizes.split(",") if x for v in volumes]:
        U.clear_scene()
        r = bench_settle(api, n, volume)
        settle.append(r)
        print("%7d vertices, %s: settled %d updates after the last move, %.0f ms CPU (%.0f ms wall; %.0f ms in a "
              "30 Hz viewport), idle update %.4f ms CPU (%.3f %% of a core at 30 Hz), %.1e from the converged pose"
              % (r["vertices"], volume, r["updates"], r["cpu_ms"], r["wall_ms"], r["viewport_ms_at_30hz"],
                 r["idle_update_cpu_ms"], r["idle_cpu_percent_at_30hz"], r["max_distance_to_converged"]), flush=True)

    os.makedirs(args.output, exist_ok=True)
    doc = {"blender": bpy.app.version_string, "frames": args.frames, "iterations": args.iterations, "rows": rows,
           "settle": settle}
    with open(os.path.join(args.output, "blender_live.json"), "w") as f:
        json.dump(doc, f, indent=1)
    with open(os.path.join(args.output, "blender_live.md"), "w") as f:
        f.write("# Live per frame vs Laplacian Deform + Hook (Blender %s)\n\n" % bpy.app.version_string)
        f.write("Open tube, bottom fifth fixed, top 5 %% on an Empty moved sideways up to 0.3 h over %d frames; "
                "%d iteration(s) per frame for both. ms from the empty's move until the mesh is up to date: "
                "median [quartiles].\n\n" % (args.frames, args.iterations))
        f.write("| V | volume | ours bind | ours frame | ours solve | LapDeform bind | LapDeform frame | LapDeform frames "
                "| ours/LapDeform |\n")
        f.write("|---:|---|---:|---:|---:|---:|---:|---:|---:|\n")
        for r in rows:
            o, s, l = r["ours_frame"], r["ours_solve"], r["laplacian_frame"]
            f.write("| %d | %s | %.1f | %.2f [%.2f–%.2f] | %.2f | %.1f | %.2f [%.2f–%.2f] | %d | %.3f |\n" % (
                r["ours"]["vertices"], r["ours"]["volume"], r["ours"]["bind_ms"], o["median"], o["p25"], o["p75"], s["median"],
                r["laplacian"]["bind_ms"], l["median"], l["p25"], l["p75"], len(r["laplacian"]["frame_ms"]),
                r["ratio"]))
        if settle:
            f.write("\n## Time to a settled pose\n\nThe add-on's default Live settings (method %s, frame budget "
                    "%.0f ms); the empty dragged 0.25 h sideways over 10 updates, then left alone. From its last "
                    "move until Live sleeps (step() returns None): updates, CPU ms and wall ms of the solving, "
                    "and the wall time in a viewport whose timer ticks at 30 Hz; then the CPU one idle update "
                    "costs, and the largest distance of the settled pose from the converged pose (the same "
                    "solver continued to tolerance 1e-10), relative to the tube's height.\n\n"
                    % (settle[0]["method"], settle[0]["frame_budget_ms"]))
            f.write("| V | volume | updates | CPU ms | wall ms | at 30 Hz | idle update (CPU ms) | idle CPU at 30 Hz "
                    "| distance / h |\n|---:|---|---:|---:|---:|---:|---:|---:|---:|\n")
            for r in settle:
                f.write("| %d | %s | %d | %.0f | %.0f | %.0f | %.4f | %.3f %% | %.1e |\n" % (
                    r["vertices"], r["volume"], r["updates"], r["cpu_ms"], r["wall_ms"], r["viewport_ms_at_30hz"],
                    r["idle_update_cpu_ms"], r["idle_cpu_percent_at_30hz"],
                    r["max_distance_to_converged"] / r["height"]))
    print("wrote %s" % os.path.join(args.output, "blender_live.md"))
    sys.stdout.flush()
    os._exit(0)


main()
