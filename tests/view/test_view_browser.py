"""`sombra view`'s page in a real browser: Debian's chromium, headless, driven by selenium through
chromium-driver. Loads the page on the smoke scene, orbits the camera, moves a light on the gizmo,
switches the technique and a knob, saves a screenshot, and checks each time that a new frame was
shown, that it differs from the one before, and what the overlay says was reused and rebuilt.

Usage: test_view_browser.py OUT_DIR   (screenshots go there; exit 77, skipped, without a browser)
"""
import os
import shutil
import sys
import time

from viewer import ROOT, Viewer

CHROMIUM, DRIVER = "/usr/bin/chromium", "/usr/bin/chromedriver"


def skip(why):
    print("skipped: " + why)
    sys.exit(77)


try:
    from selenium import webdriver
    from selenium.webdriver.chrome.service import Service
    from selenium.webdriver.common.action_chains import ActionChains
    from selenium.webdriver.common.by import By
    from selenium.webdriver.support.ui import Select
except ImportError:
    skip("python3-selenium is not installed (scripts/install-deps.sh installs it)")
if not (os.path.exists(CHROMIUM) and os.path.exists(DRIVER)):
    skip("chromium and chromium-driver are not installed (scripts/install-deps.sh installs them)")


def wait_for(what, condition, seconds=300):
    deadline = time.time() + seconds
    while time.time() < deadline:
        value = condition()
        if value:
            return value
        time.sleep(0.1)
    raise AssertionError("timed out waiting for " + what)


def main():
    out = sys.argv[1] if len(sys.argv) > 1 else "."
    os.makedirs(out, exist_ok=True)
    viewer = Viewer(os.path.join(ROOT, "data", "scenes", "smoke.json"), "--quiet")
    options = webdriver.ChromeOptions()
    options.binary_location = CHROMIUM
    for flag in ["--headless=new", "--no-sandbox", "--disable-gpu", "--disable-dev-shm-usage", "--window-size=1100,760",
                 "--user-data-dir=" + os.path.join(out, "chromium-profile")]:
        options.add_argument(flag)
    browser = webdriver.Chrome(service=Service(DRIVER), options=options)
    try:
        browser.get(viewer.url + "/")
        state = lambda: browser.execute_script(
            "const v = window.sombraView; return v && {frames: v.framesShown, draft: v.lastDraft, error: v.lastError, busy: v.busy(),"
            " src: document.getElementById('frame').src, overlay: document.getElementById('overlay').textContent};")

        def next_full_frame(after, what):
            # the full frame that follows the action (drafts may come first); no error shown
            s = wait_for(what, lambda: (lambda s: s if s and s["frames"] > after and not s["draft"] and not s["busy"] else None)(state()))
            assert not s["error"], what + ": " + s["error"]
            return s

        # the page asks for a full frame at the scene's size on load; make the maps small for speed
        first = next_full_frame(0, "the first frame")
        assert "dsm" in first["overlay"] and "512×512" in first["overlay"], first["overlay"]
        resolution = browser.find_element(By.ID, "option-dsm_resolution")
        resolution.clear()
        resolution.send_keys("128\n")
        small = next_full_frame(first["frames"], "the frame at --dsm-res 128")
        assert "rebuilt: " in small["overlay"] and "DSM views" in small["overlay"].split("rebuilt: ")[1], small["overlay"]
        browser.save_screenshot(os.path.join(out, "viewer-dsm.png"))

        # orbit: drag on the frame; the maps are kept, the frame changes
        image = browser.find_element(By.ID, "frame")
        ActionChains(browser).move_to_element(image).click_and_hold().move_by_offset(40, 0).move_by_offset(40, 10).release().perform()
        orbited = next_full_frame(small["frames"], "the orbited frame")
        assert orbited["src"] != small["src"], "orbiting did not change the frame"
        reused = orbited["overlay"].split("reused:  ")[1].split("\n")[0]
        assert "scene data" in reused and "DSM views" in reused, orbited["overlay"]

        # move light 0 on the gizmo: its maps are rebuilt, the frame changes
        gizmo = browser.find_element(By.ID, "gizmo")
        ActionChains(browser).move_to_element_with_offset(gizmo, 30, -30).click_and_hold().move_by_offset(-20, 10).release().perform()
        lit = next_full_frame(orbited["frames"], "the frame with the moved light")
        assert lit["src"] != orbited["src"], "moving the light did not change the frame"
        since = browser.execute_script("return window.sombraView.overlays.slice(arguments[0] - arguments[1]);",
                                       lit["frames"], orbited["frames"])
        assert any("DSM views" in o.split("rebuilt: ")[1] for o in since), since  # by the drafts or the full frame

        # switch to low-pass shadows: summed-area tables are built, the frame changes
        Select(browser.find_element(By.ID, "technique")).select_by_value("lowpass")
        lowpass = next_full_frame(lit["frames"], "the low-pass frame")
        assert lowpass["src"] != lit["src"] and "lowpass" in lowpass["overlay"] and "SATs" in lowpass["overlay"], lowpass["overlay"]
        # a knob of the new technique; the same tables are read with another filter width
        width = browser.find_element(By.ID, "option-lowpass_filter_width")
        width.clear()
        width.send_keys("12\n")
        wider = next_full_frame(lowpass["frames"], "the frame with W = 12")
        assert wider["src"] != lowpass["src"]
        browser.save_screenshot(os.path.join(out, "viewer-lowpass.png"))

        # a refused value shows the server's message and keeps the frame
        width.clear()
        width.send_keys("-1\n")
        message = wait_for("the error", lambda: state()["error"])
        assert "options.lowpass_filter_width" in message, message
        assert browser.find_element(By.ID, "error").is_displayed()
        print("passed: the page orbited, moved a light, switched to lowpass and changed W; overlays:\n" + wider["overlay"])
    finally:
        browser.quit()
        viewer.close()
        shutil.rmtree(os.path.join(out, "chromium-profile"), ignore_errors=True)


if __name__ == "__main__":
    main()
