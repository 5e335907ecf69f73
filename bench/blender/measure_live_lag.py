# How a Live drag feels in a real Blender window (Xvfb, software OpenGL):
# the main thread's time per Live update, and how far the Empty trails the
# mouse during a G drag. Not a test (no assertions): a measurement.
#
#   xvfb-run -a -s "-screen 0 1280x800x24" python3 bench/blender/measure_live_lag.py \
#       --blender blender --addon-dir build/addon --sizes 10000,50000,156000 --out build/lag [--label new]
#
# Per size: Blender starts with lag_session.py (a tube, bottom fifth fixed, top
# on an Empty), Live starts, the pointer is put on the viewport, G is pressed
# and the pointer moves 300 px right in 60 steps, one every 1/60 s; it rests for
# 1.5 s, a click confirms, and Live is left to settle (at most 300 s).
# From the two logs (the driver's pointer times, Blender's redraws and
# updates, both on the monotonic clock):
#   update ms   the main thread's time per Live update that changed the mesh (median, 90th pct, max)
#   lag ms      per redraw during the drag: its time minus when the pointer had reached the place
#               the drawn Empty shows (the pointer-to-Empty ratio taken from the final positions)
#   move lag ms the same per move of the Empty (G applies the pointer's events to it between redraws)
#   catch-up ms from the pointer's last move to the first redraw showing the Empty within 1 % of its end
#   fps         redraws per second during the drag
#   settle s    from the click to Live's "settled"
# Writes <out>/<label>.json and prints a Markdown table.
import argparse
import json
import os
import statistics
import subprocess
import sys
import time

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, "..", "..", "blender_tests", "gui"))
from gui_driver import Gui  # noqa: E402  (the GUI suite's driver: Blender in a window, xdotool)

STEPS, STEP_PX, STEP_S = 60, 5, 1.0 / 60.0


def pct(values, q):
    if not values:
        return float("nan")
    v = sorted(values)
    return v[min(len(v) - 1, int(q * (len(v) - 1) + 0.5))]


def drag(gui, centre):
    """G and a steady drag; returns [(time, pointer dx)]."""
    x, y = centre
    gui.xdo("mousemove", str(x), str(y))
    gui.settle()
    pointer = [(time.monotonic(), 0)]
    gui.xdo("key", "g")
    gui.settle(2)
    start = time.monotonic()
    for i in range(1, STEPS + 1):
        while time.monotonic() < start + i * STEP_S:
            time.sleep(0.001)
        subprocess.run(["xdotool", "mousemove", str(x + STEP_PX * i), str(y)], check=True)
        pointer.append((time.monotonic(), STEP_PX * i))
    return pointer


def when_pointer_reached(pointer, px):
    """The time the pointer first reached `px` (linear between the logged steps)."""
    for (t0, p0), (t1, p1) in zip(pointer, pointer[1:]):
        if p1 >= px:
            return t0 if p1 == p0 else t0 + (t1 - t0) * (px - p0) / (p1 - p0)
    return pointer[-1][0]


def measure(blender, addon_dir, vertices, out):
    gui = Gui(blender, out, os.path.join(HERE, "lag_session.py"), os.path.abspath(addon_dir), str(vertices))
    try:
        s0 = gui.wait("scene set-up", lambda s: s.get("ready") and "viewport_centre" in s, timeout=600)
        gui.settle()
        gui.xdo("key", "Escape")   # the splash screen
        gui.settle()
        gui.command("cmd_live")
        gui.wait("Live to settle at rest", lambda s: s.get("live_running") and s.get("settled"), timeout=600)
        x0 = gui.state()["empty_x"]
        pointer = drag(gui, s0["viewport_centre"])
        last_move = pointer[-1][0]
        time.sleep(1.5)
        gui.xdo("click", "1")
        click = time.monotonic()
        settled = gui.wait("Live to settle", lambda s: s.get("settled") and s.get("now", 0) > click + 0.2,
                           timeout=300)
        settle_s = settled["now"] - click
        gui.command("cmd_dump")
        gui.wait("the record", lambda s: os.path.exists(os.path.join(out, "record.json")))
        time.sleep(0.5)
        with open(os.path.join(out, "record.json")) as f:
            record = json.load(f)
        gui.xdo("key", "Escape")
    finally:
        gui.quit()
    draws = record["draws"]
    x_end = settled["empty_x"]
    ratio = (x_end - x0) / pointer[-1][1]
    def lags_of(samples):
        # During the drag, and after it while the Empty is still on its way (then it lags the last move).
        return [s[0] - when_pointer_reached(pointer, (s[1] - x0) / ratio) for s in samples
                if s[0] >= pointer[1][0] and 0.02 < (s[1] - x0) / (x_end - x0) and
                (s[0] <= last_move or (s[1] - x0) / (x_end - x0) < 0.99)]

    lags, move_lags = lags_of(draws), lags_of(record["moves"])
    caught = next((t for t, x, _ in draws if t >= last_move and abs(x - x_end) <= 0.01 * abs(x_end - x0)), None)
    in_drag = [t for t, _, _ in draws if pointer[0][0] <= t <= last_move]
    updates = [u[1] for u in record["updates"] if u[0] >= pointer[0][0]]
    return {"vertices": s0["vertices"], "update_method": s0.get("update_method"),
            "update_ms_median": statistics.median(updates) if updates else float("nan"),
            "update_ms_p90": pct(updates, 0.9), "update_ms_max": max(updates, default=float("nan")),
            "updates": len(updates),
            "lag_ms_median": 1e3 * statistics.median(lags) if lags else float("nan"),
            "lag_ms_p90": 1e3 * pct(lags, 0.9),
            "move_lag_ms_median": 1e3 * statistics.median(move_lags) if move_lags else float("nan"),
            "catch_up_ms": 1e3 * (caught - last_move) if caught is not None else float("nan"),
            "fps": len(in_drag) / max(1e-9, last_move - pointer[0][0]),
            "settle_s": settle_s}


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--blender", default="blender")
    ap.add_argument("--addon-dir", required=True, help="a staged build/addon folder")
    ap.add_argument("--sizes", default="10000,50000,156000")
    ap.add_argument("--out", required=True)
    ap.add_argument("--label", default="live")
    args = ap.parse_args()
    rows = []
    for n in (int(v) for v in args.sizes.split(",")):
        row = measure(args.blender, args.addon_dir, n, os.path.join(args.out, "%s_%d" % (args.label, n)))
        rows.append(row)
        print(json.dumps(row), flush=True)
    os.makedirs(args.out, exist_ok=True)
    with open(os.path.join(args.out, args.label + ".json"), "w") as f:
        json.dump(rows, f, indent=1)
    print("| vertices | update ms median / p90 / max | lag ms median / p90 | move lag ms | catch-up ms | fps "
          "| settle s |")
    print("|---:|---:|---:|---:|---:|---:|---:|")
    for r in rows:
        print("| %d | %.1f / %.1f / %.1f | %.0f / %.0f | %.0f | %.0f | %.1f | %.1f |"
              % (r["vertices"], r["update_ms_median"], r["update_ms_p90"], r["update_ms_max"], r["lag_ms_median"],
                 r["lag_ms_p90"], r["move_lag_ms_median"], r["catch_up_ms"], r["fps"], r["settle_s"]))


if __name__ == "__main__":
    sys.exit(main())
