# GUI suite driver: runs under `xvfb-run -a -s "-screen 0 1280x800x24"`.
# Starts Blender with its UI and gui_session.py, then uses real X input
# (xdotool) to move the handle empty with G while ARAP Live runs, checks the
# mesh followed, Esc restores it exactly, and Enter + Ctrl+Z undo works.
# Screenshots (imagemagick `import -window root`) go to <out>/*.png.
#
# Every wait is on state that gui_session.py reports (state.json), never a
# fixed sleep: "tick" advances each time Blender's event loop has run, so
# after sending input the driver waits for a few ticks, or for the effect it
# expects. Limits are generous (a loaded 2-core machine, software OpenGL); on
# a failure the screenshot (failure.png) and Blender's log stay in <out>.
import argparse
import os
import sys

from gui_driver import WINDOW_HEIGHT, Fail, Gui, moved


def run(gui):
    s0 = gui.wait("scene set-up", lambda s: s.get("ready") and "viewport_centre" in s, timeout=300)
    if s0.get("aliases") or s0.get("policy_warnings"):
        raise Fail("the add-on is under other module names %s or Blender lists policy warnings %s"
                   % (s0.get("aliases"), s0.get("policy_warnings")))
    print("installed clean: no module under another name, no policy warning")
    gui.settle()
    gui.xdo("key", "Escape")  # close the splash screen (Live is not running yet)
    gui.settle()
    # Click down the sidebar's tab column until the ARAP tab is hit (the
    # panel's appended draw hook then reports it); other tabs are harmless.
    x, top = s0["sidebar_tabs"]
    for y in range(top + 10, top + 400, 15):
        if gui.state().get("panel_drawn"):
            break
        gui.xdo("mousemove", str(x), str(y), "click", "1")
        gui.settle(2)
    if not gui.state().get("panel_drawn"):
        raise Fail("the ARAP sidebar panel was never drawn")
    gui.shot("01_start.png")
    gui.command("cmd_live")
    s1 = gui.wait("Live running", lambda s: s.get("live_running"))
    print("Live started:", s1.get("live_invoke"), "frame ms", s1.get("frame_ms"))
    gui.drag_with_g(s1["viewport_centre"], 70, -20,
                    lambda s: moved(s["top_centroid"], s0["top_centroid"]) > 0.05)
    s2 = gui.wait("the mesh to follow the empty",
                  lambda s: moved(s["empty_location"], s0["empty_location"]) > 0.05
                  and moved(s["top_centroid"], s0["top_centroid"]) > 0.05)
    sd = gui.during_drag
    print("during the drag (before the click): empty moved by %.3f, top centroid by %.3f"
          % (moved(sd["empty_location"], s0["empty_location"]), moved(sd["top_centroid"], s0["top_centroid"])))
    d_empty = [a - b for a, b in zip(s2["empty_location"], s0["empty_location"])]
    d_top = [a - b for a, b in zip(s2["top_centroid"], s0["top_centroid"])]
    print("empty moved by", d_empty, "top centroid moved by", d_top)
    if moved(d_empty, d_top) > 0.02 * max(1.0, moved(d_empty, [0, 0, 0])) + 1e-3:
        raise Fail("top vertices did not follow the empty: %s vs %s" % (d_top, d_empty))
    if not s2.get("live_running"):
        raise Fail("Live stopped after the move")
    gui.shot("02_after_move.png")
    check_live_status(sd)

    # Right-click belongs to Blender (here: the object context menu), it does not cancel Live.
    cx, cy = s1["viewport_centre"]
    gui.xdo("mousemove", str(cx), str(cy))
    gui.xdo("click", "3")
    gui.settle(3)
    gui.shot("02b_right_click_menu.png")
    # Close the menu by clicking the status bar (the window's bottom row): Blender 3.x closes a
    # menu once the pointer leaves it, 5.x keeps it open until a click; either way the click
    # lands on a bar that does nothing and makes no undo step (x=200: left of the reports,
    # a click on which would open the Info log).
    gui.xdo("mousemove", "200", str(WINDOW_HEIGHT - 10), "click", "1")  # left of any report
    if not gui.settle(5).get("live_running"):
        raise Fail("right-click cancelled Live")
    print("right-click left Live running")

    # Ctrl+Z undoes the last move: the Empty goes back and Live goes on posing it.
    gui.xdo("mousemove", str(cx), str(cy))
    gui.xdo("key", "ctrl+z")
    gui.wait("Ctrl+Z to take the Empty back while Live goes on",
             lambda s: s.get("live_running") and moved(s["empty_location"], s0["empty_location"]) < 1e-6
             and moved(offset(s), offset(s0)) < 0.02)
    print("Ctrl+Z during Live took the last move back; Live goes on")
    gui.command("cmd_select_empty")   # the undo step had the bar selected, as the set-up left it
    gui.wait("the Empty selected again", lambda s: s.get("active") == "TopEmpty")
    gui.drag_with_g(s1["viewport_centre"], 50, 30,
                    lambda s: moved(s["top_centroid"], s0["top_centroid"]) > 0.05)

    gui.xdo("mousemove", str(cx), str(cy))
    gui.xdo("key", "Escape")
    gui.wait("Esc to cancel Live", lambda s: not s.get("live_running"))
    s3 = gui.settle()
    if s3["hash"] != s0["rest_hash"]:
        raise Fail("Esc did not restore the mesh bit for bit")
    if s3["empty_location"] != s0["empty_location"]:
        raise Fail("Esc did not put the Empty back: %s, was %s" % (s3["empty_location"], s0["empty_location"]))
    print("Esc restored the mesh and the Empty exactly")
    gui.shot("03_after_cancel.png")

    # Apply with Enter, then Ctrl+Z until the empty is back: the mesh is at rest again.
    gui.command("cmd_live")
    s4 = gui.wait("Live running again", lambda s: s.get("live_running"))
    gui.drag_with_g(s4["viewport_centre"], -60, 20,
                    lambda s: moved(s["top_centroid"], s3["top_centroid"]) > 0.05)
    gui.xdo("key", "Return")
    s5 = gui.wait("Enter to apply", lambda s: not s.get("live_running"))
    if s5["hash"] == s0["rest_hash"]:
        raise Fail("Enter did not keep the pose")
    gui.shot("04_after_apply.png")
    print("Enter applied the pose")
    # The Empty is still the active object: the ARAP panel stays, showing the posed mesh.
    draws = gui.state().get("panel_draws", 0)
    x, top = s0["sidebar_tabs"]
    gui.xdo("mousemove", str(x - 120), str(top + 120))   # over the sidebar: it redraws
    gui.wait("the panel to stay while the Empty is active",
             lambda s: s.get("panel_draws", 0) > draws and s.get("panel_active") == "TopEmpty"
             and s.get("panel_mesh") == "Bar")
    print("the ARAP panel stays with the Empty active")
    # Each G move made while Live ran is its own undo step (Blender's transform
    # pushes it, with the mesh as Live had it then); the set-up is the step before.
    undos = 0
    for undos in range(1, 6):
        gui.xdo("key", "ctrl+z")
        s6 = gui.settle(5)
        if s6["hash"] == s0["rest_hash"]:
            break
    print("Ctrl+Z presses to reach the rest shape:", undos)
    if s6["hash"] != s0["rest_hash"]:
        raise Fail("Ctrl+Z did not bring the mesh back to rest (empty at %s)" % s6["empty_location"])
    print("Ctrl+Z restored the rest shape")
    gui.shot("05_after_undo.png")
    # Deform from the keyboard: the redo panel (F9) shows the values it used, not placeholders.
    gui.command("cmd_redo_settings")
    gui.settle()
    gui.xdo("mousemove", *map(str, s1["viewport_centre"]))
    gui.xdo("key", "ctrl+alt+shift+d")
    redo = gui.wait("Deform to run from the keyboard",
                    lambda s: s.get("redo", {}).get("operator") == "OBJECT_OT_arap_deform")["redo"]
    print("redo panel after Deform:", redo)
    if (redo["operator"], redo["max_iterations"], redo["init"]) != ("OBJECT_OT_arap_deform", 37, "LAPLACIAN") \
            or abs(redo["tolerance"] - 1e-5) > 1e-9:
        raise Fail("the redo panel does not show the values Deform used: %s" % redo)
    auto_mode(gui)
    big_deform(gui)
    setup_undo(gui)
    shot_path = os.path.join(gui.out, "06_blender_screenshot.png")
    gui.command("cmd_screenshot", shot_path)
    gui.wait("Blender's own screenshot", lambda s: os.path.exists(shot_path))
    with open(os.path.join(gui.out, "blender.log")) as f:
        log = f.read()
    if "Traceback" in log:
        raise Fail("Python errors in Blender's log (panel drawing, operators):\n" + log[-3000:])


def check_live_status(s):
    """During G, Live says what it does in the viewport's corner (Blender's status bar is full of
    the transform's own hints there): settling or settled, the update time, Enter and Esc."""
    lines = s.get("overlay", [])
    print("viewport status during the drag:", lines)
    if not lines or "ARAP Live on 'Bar'" not in lines[0] or "Esc: cancel" not in lines[-1]:
        raise Fail("the viewport does not show Live's status during G: %r" % lines)
    if not any("ms per update" in line for line in lines):
        raise Fail("Live's status does not give the update time: %r" % lines)


def big_deform(gui):
    """Deform on a finer mesh, set to run for minutes: the viewport shows its progress and keeps
    running (Blender's event loop ticks on), and Esc stops it with the mesh untouched."""
    gui.command("cmd_big_deform")
    s0 = gui.wait("Deform running with its progress shown",
                  lambda s: s.get("deform_running") and any("ARAP Deform on 'Big'" in line
                                                            for line in s.get("overlay", [])))
    if s0.get("deform_invoke") != ["RUNNING_MODAL"]:
        raise Fail("Deform from the panel did not run modal: %s" % s0.get("deform_invoke"))
    s1 = gui.settle(ticks=10)   # the event loop goes on while the worker solves
    if not s1.get("deform_running"):
        raise Fail("the minutes-long Deform ended by itself: %s" % s1.get("overlay"))
    progress = [line for line in s1["overlay"] if "ARAP Deform on 'Big'" in line]
    print("Deform's progress while the viewport runs:", progress, "(%d vertices)" % s1.get("big_vertices", 0))
    gui.shot("09_deform_progress.png")
    gui.xdo("mousemove", *map(str, s0["viewport_centre"]))
    gui.xdo("key", "Escape")
    s2 = gui.wait("Esc to stop Deform", lambda s: not s.get("deform_running"))
    if s2.get("big_now_hash") != s2.get("big_hash"):
        raise Fail("Esc stopped Deform but the mesh was changed")
    if any("ARAP Deform" in line for line in gui.settle().get("overlay", [])):
        raise Fail("Deform's progress stayed in the viewport after Esc")
    print("Esc stopped Deform; the mesh is untouched")


def setup_undo(gui):
    """Set Fixed, then Add Handle, pressed in Edit Mode; Ctrl+Z once takes the handle back and keeps the
    fixed group; Set Fixed again reuses it (no ARAP_Fixed.001)."""
    gui.command("cmd_rig")
    s0 = gui.wait("the Rig in Edit Mode", lambda s: (s.get("rig") or {}).get("mode") == 'EDIT')
    gui.xdo("mousemove", *map(str, s0["viewport_centre"]))
    gui.xdo("key", "ctrl+alt+shift+f")
    gui.wait("Set Fixed from Selection", lambda s: s["rig"]["fixed_group"] == "ARAP_Fixed")
    gui.command("cmd_rig_top")
    gui.settle()
    gui.xdo("key", "ctrl+alt+shift+h")
    s1 = gui.wait("Add Handle from Selection", lambda s: len(s["rig"]["handles"]) == 1)
    print("the Rig's set-up:", s1["rig"])
    if s1["rig"]["handles"] != [["ARAP_Handle_1", "Rig_ARAP_Handle_1"]]:
        raise Fail("the new handle's names do not say whose it is: %s" % s1["rig"]["handles"])
    gui.xdo("key", "ctrl+z")
    gui.wait("Ctrl+Z to take the handle back", lambda s: not s["rig"]["handles"])
    rig = gui.settle()["rig"]
    print("after Ctrl+Z:", rig)
    if rig["fixed_group"] != "ARAP_Fixed" or "ARAP_Fixed" not in rig["groups"]:
        raise Fail("Ctrl+Z after Add Handle lost the fixed group: %s" % rig)
    named = {rig["fixed_group"]} | {h[0] for h in rig["handles"]}
    stray = [g for g in rig["groups"] if g.startswith("ARAP_") and g not in named]
    if stray or rig["empties"]:
        raise Fail("after Ctrl+Z the vertex groups or Empties disagree with the settings: %s" % rig)
    gui.xdo("key", "ctrl+alt+shift+f")
    rig = gui.settle(5)["rig"]
    if [g for g in rig["groups"] if g.startswith("ARAP_Fixed")] != ["ARAP_Fixed"]:
        raise Fail("Set Fixed again made a second fixed group: %s" % rig["groups"])
    print("Edit Mode set-up and its undo keep the settings and the groups together")


def offset(s):
    return [a - b for a, b in zip(s["top_centroid"], s["empty_location"])]


def auto_mode(gui):
    """Auto mode, no Live: G on the Empty poses the mesh; playback poses every frame.
    The handle moves rigidly with its Empty, so the top vertices keep their
    offset from it (`follows`)."""
    gui.command("cmd_auto")
    s0 = gui.wait("Auto mode on", lambda s: s.get("auto") and not s.get("live_running"))
    rest_offset = offset(s0)

    def follows(s, tol=0.02):
        return moved(offset(s), rest_offset) < tol

    gui.drag_with_g(s0["viewport_centre"], 50, -30,
                    lambda s: moved(s["top_centroid"], s0["top_centroid"]) > 0.05)
    s1 = gui.wait("the mesh to follow with Auto", lambda s: follows(s) and moved(s["empty_location"],
                                                                               s0["empty_location"]) > 0.05)
    print("Auto: the top vertices followed G to", s1["top_centroid"])
    gui.shot("07_auto_after_move.png")
    gui.command("cmd_animate")
    gui.wait("keyframes", lambda s: s.get("frame") == 1 and follows(s))
    gui.xdo("mousemove", *map(str, s0["viewport_centre"]))
    gui.xdo("key", "space")   # Play (the default keymap's Spacebar action)
    s2 = gui.wait("playback to reach frame 10", lambda s: s.get("playing") and s.get("frame", 0) >= 10)
    gui.shot("08_auto_playback.png")
    if not follows(s2, tol=0.05):
        raise Fail("during playback the top vertices (%s) did not follow the Empty (%s)"
                   % (s2["top_centroid"], s2["empty_location"]))
    # Each frame played is solved from the cold start on a second solver: once all are, the loops show
    # the final poses from the cache.
    s_final = gui.wait("every frame of the range final while playing",
                       lambda s: s.get("playing") and s.get("auto_frames_final")
                       and s["auto_frames_final"][0] == s["auto_frames_final"][1], timeout=240)
    print("Auto: %d of %d frames final while playing" % tuple(s_final["auto_frames_final"]))
    shown = [gui.settle(1) for _ in range(8)]
    not_final = [(s["frame"], s.get("auto_shown_final")) for s in shown if s.get("playing")
                 and not s.get("auto_shown_final")]
    if not_final:
        raise Fail("once every frame was final, playback still showed previews at (frame, final) %s" % not_final)
    print("Auto: the next loops show the final poses (frames %s)" % [s["frame"] for s in shown])
    gui.xdo("key", "Escape")   # stop playback (Blender goes back to the frame it started from)
    s3 = gui.wait("playback to stop and the pose to settle", lambda s: not s.get("playing") and follows(s))
    if not s3.get("auto"):
        raise Fail("Auto mode stopped: %s" % s3.get("auto_status"))
    print("Auto: playback reached frame %d, stopped at frame %d, the pose follows" % (s2["frame"], s3["frame"]))


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--blender", default="blender")
    ap.add_argument("--out", required=True)
    args = ap.parse_args()
    gui = Gui(args.blender, args.out, "gui_session.py")
    try:
        run(gui)
    except Fail as exc:
        gui.shot("failure.png")
        gui.quit()
        print("GUI TEST FAILED:", exc)
        print("Screenshot: %s; Blender's log: %s" % (os.path.join(args.out, "failure.png"),
                                                   os.path.join(args.out, "blender.log")))
        with open(os.path.join(args.out, "blender.log"), errors="replace") as f:
            print("--- last lines of Blender's log ---\n" + "".join(f.readlines()[-40:]))
        sys.exit(1)
    finally:
        gui.quit()
    print("GUI TEST OK; screenshots in", args.out)


main()
