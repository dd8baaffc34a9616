"""`sombra view`'s HTTP API (docs/viewer.md): frames, reuse, validation, saved scenes, and a server
that stays up with bounded memory under malformed requests, dropped clients and bursts."""
import base64
import json
import os
import socket
import subprocess
import threading
import urllib.error
import urllib.request

import pytest

from viewer import ROOT, SOMBRA, Viewer, call, decode_png

SMOKE = os.path.join(ROOT, "data", "scenes", "smoke.json")
SMALL = {"width": 48, "height": 48, "dsm_resolution": 64}


@pytest.fixture(scope="module")
def viewer():
    v = Viewer(SMOKE, "--quiet")
    yield v
    assert v.close() == 0  # SIGTERM stops it cleanly


def frame(viewer, **request):
    request.setdefault("options", dict(SMALL))
    status, body = viewer.post("/api/frame", request)
    reply = json.loads(body)
    assert status == 200, reply
    return reply


def error_of(viewer, request, path="/api/frame"):
    status, body = viewer.post(path, request)
    assert status == 400, body
    return json.loads(body)["error"]


def test_state_lists_the_scene_and_every_option(viewer):
    status, body = viewer.get("/api/state")
    state = json.loads(body)
    assert status == 200
    assert state["image"] == {"width": 512, "height": 512}
    assert [t["name"] for t in state["techniques"]][:3] == ["none", "rays", "dsm"]
    options = {o["key"]: o for o in state["options"]}
    assert options["dsm_resolution"]["kind"] == "integer" and options["dsm_resolution"]["techniques"] == ["dsm", "shadowmap"]
    assert options["shadows"]["value"] == "dsm"
    assert len(state["lights"]) >= 1 and "direction" in state["lights"][0]


def test_page_is_served_and_nothing_from_the_file_system(viewer):
    status, body = viewer.get("/")
    assert status == 200 and b"sombra view" in body and b"/api/frame" in body
    for path in ["/etc/passwd", "/../../etc/passwd", "/api/../../../etc/passwd", "/data/scenes/smoke.json", "/page.html"]:
        status, body = viewer.get(path)
        assert status == 404, path
        assert b"root:" not in body


def test_foreign_hosts_and_non_json_posts_are_refused(viewer):
    # a foreign name resolved to 127.0.0.1 (DNS rebinding) cannot read the page or the API
    for path in ["/", "/api/state"]:
        request = urllib.request.Request(viewer.url + path, headers={"Host": "evil.example:" + viewer.url.rsplit(":", 1)[1]})
        with pytest.raises(urllib.error.HTTPError) as refused:
            urllib.request.urlopen(request, timeout=60)
        assert refused.value.code == 403 and b"does not name this server" in refused.value.read()
    # a text/plain POST (what another origin may send without a CORS preflight) renders nothing
    request = urllib.request.Request(viewer.url + "/api/frame", data=b"{}", headers={"Content-Type": "text/plain"})
    with pytest.raises(urllib.error.HTTPError) as refused:
        urllib.request.urlopen(request, timeout=60)
    assert refused.value.code == 415
    port = viewer.url.rsplit(":", 1)[1]
    for host in ["localhost:" + port, "127.0.0.1:" + port, "10.1.2.3:" + port]:  # any IP address: no name to rebind
        assert call_with_host(viewer.url + "/api/state", host) == 200
    with pytest.raises(urllib.error.HTTPError) as refused:
        call_with_host(viewer.url + "/api/state", "localhost:1")  # another port
    assert refused.value.code == 403


def call_with_host(url, host):
    with urllib.request.urlopen(urllib.request.Request(url, headers={"Host": host}), timeout=60) as reply:
        return reply.status


def test_a_frame_is_a_png_of_the_asked_size_with_stats(viewer):
    reply = frame(viewer)
    width, height, rows = decode_png(base64.b64decode(reply["png"]))
    assert (width, height) == (48, 48) == (reply["width"], reply["height"])
    assert reply["stats"]["frame_ms"] > 0 and "camera_pass" in reply["stats"]["stage_ms"]
    assert max(max(row) for row in rows) > 0  # not a black frame


def test_a_moved_camera_reuses_the_maps_and_a_moved_light_rebuilds_them(viewer):
    state = json.loads(viewer.get("/api/state")[1])
    camera = state["camera"]
    frame(viewer)
    moved = dict(camera, position=[p * 1.1 for p in camera["position"]])
    reply = frame(viewer, camera=moved)
    assert reply["stats"]["reused_preparation"] is True
    assert reply["stats"]["dsm"]["views_generated"] == 0
    light = state["lights"][0]
    turned = [{"direction": [light["direction"][0] + 0.2, light["direction"][1], light["direction"][2]]}] + [{}] * (len(state["lights"]) - 1)
    reply = frame(viewer, camera=moved, lights=turned)
    assert reply["stats"]["dsm"]["views_generated"] >= 1


@pytest.mark.parametrize("request_body, message", [
    ({"options": {"dsm_resolution": 0}}, "options.dsm_resolution: must lie in"),
    ({"options": {"dsm_resolutoin": 64}}, "options: unknown key 'dsm_resolutoin' (did you mean 'dsm_resolution'?)"),
    ({"options": {"shadows": "dms"}}, "options.shadows: unknown value 'dms'"),
    ({"options": {"lowpass_filter_width": 3}}, "options.lowpass_filter_width: applies to"),
    ({"options": {"width": "wide"}}, "options.width: expected"),
    ({"options": []}, "options: expected an object"),
    ({"camera": {"up": [0, 0, 0]}}, "camera.up"),
    ({"camera": {"position": [0, 0, 1e300]}}, "camera.position[2]: must be a finite number of magnitude"),
    ({"camera": {"fov_y_deg": 500}}, "camera.fov_y_deg"),
    ({"lights": []}, "lights: expected an array of"),
    ({"lights": [{"direction": [0, 0, 0]}, {}]}, "lights[0].direction"),
    ({"lights": [{}, {"position": [0, 0, 0]}]}, "lights[1].position: a directional light has no position"),
    ({"lights": [{}, {"direction": [0, 0, 1], "colour": [1, 0, 0]}]}, "lights[1]: unknown key 'colour'"),
    ({"opacity_scale": 0}, "opacity_scale: must lie in (0, 100]"),
    ({"zoom": 2}, "unknown key 'zoom'"),
])
def test_bad_parameters_get_400_and_the_message_naming_the_field(viewer, request_body, message):
    body = json.dumps(request_body).encode()
    assert message in error_of(viewer, body)
    assert message in error_of(viewer, body, "/api/scene")


def test_malformed_and_oversized_requests(viewer):
    assert "not JSON" in error_of(viewer, b"{\"options\": ")
    assert "not JSON" in error_of(viewer, b"\xff\xfe garbage")
    status, _ = viewer.post("/api/frame", b"[" * (2 << 20))
    assert status == 413
    with _connect(viewer) as s:
        s.sendall(b"NONSENSE / HTTP/9\r\n\r\n")
        assert s.recv(100).startswith(b"HTTP/1.1 400")
    assert viewer.get("/api/state")[0] == 200


def _connect(viewer):
    host, port = viewer.url.replace("http://", "").rsplit(":", 1)
    return socket.create_connection((host, int(port)), timeout=60)


@pytest.fixture
def own_viewer():
    """A server for one test alone: a dropped request that it reads late cannot overtake another
    test's frame."""
    v = Viewer(SMOKE, "--quiet")
    yield v
    assert v.close() == 0


def test_a_client_that_disconnects_mid_frame_leaves_it_running(own_viewer):
    viewer = own_viewer
    body = json.dumps({"options": {"width": 200, "height": 200, "dsm_resolution": 64}}).encode()
    for _ in range(3):
        with _connect(viewer) as s:
            s.sendall(b"POST /api/frame HTTP/1.1\r\nHost: " + viewer.url[len("http://"):].encode() +
                      b"\r\nContent-Type: application/json\r\nContent-Length: "
                      + str(len(body)).encode() + b"\r\n\r\n" + body)
        # closed before the frame is rendered and written
    # The server may read a closed request only after ours (slow under the sanitizers); each one it
    # reads later takes a newer ticket and makes ours stale (409). Three of them can do that at most
    # three times, so the fourth try must render.
    for _ in range(4):
        status, body = viewer.post("/api/frame", {"options": dict(SMALL)})
        if status != 409:
            break
        assert json.loads(body)["stale"] is True
    assert status == 200, body
    assert json.loads(body)["width"] == 48


def test_a_saved_scene_renders_to_the_same_frame(viewer, tmp_path):
    state = json.loads(viewer.get("/api/state")[1])
    camera = dict(state["camera"], position=[p * 0.9 + 0.05 for p in state["camera"]["position"]])
    lights = [{"direction": [0.3, -0.8, -0.5]}] + [{}] * (len(state["lights"]) - 1)
    request = {"options": {"width": 40, "height": 32, "dsm_resolution": 96, "dsm_epsilon": 0.01}, "camera": camera,
               "lights": lights, "opacity_scale": 1.7}
    reply = frame(viewer, **request)
    status, text = viewer.post("/api/scene", request)
    assert status == 200
    saved = json.loads(text)
    assert saved["image"] == {"width": 40, "height": 32}
    assert saved["render"]["dsm_resolution"] == 96 and "width" not in saved["render"]
    assert all(os.path.isabs(v["file"]) for v in saved["volumes"] if "file" in v)
    scene = tmp_path / "saved.json"
    scene.write_bytes(text)
    out = tmp_path / "saved.png"
    subprocess.run([SOMBRA, "render", str(scene), "-o", str(out), "-q"], check=True, cwd=str(tmp_path))
    _, _, viewed = decode_png(base64.b64decode(reply["png"]))
    width, height, rendered = decode_png(out.read_bytes())
    assert (width, height) == (40, 32)
    worst = max(abs(a - b) for r1, r2 in zip(viewed, rendered) for a, b in zip(r1, r2))
    assert worst <= 1, worst  # the same frame: at most one 8-bit level (a light direction renormalised on load)


def test_a_burst_of_requests_leaves_it_answering_with_bounded_memory(viewer):
    frame(viewer)
    before = viewer.rss_kib()
    answers = {}
    lock = threading.Lock()

    def client(k):
        for i in range(25):
            body = (b"{bad" if (k + i) % 5 == 0 else
                    json.dumps({"options": {"width": 16 + (i % 4), "height": 16, "dsm_resolution": 64}}).encode())
            try:
                status, _ = call(viewer.url + "/api/frame", body, timeout=600)
            except OSError as e:  # a refused or reset connection counts, but must not stop the server
                status = type(e).__name__
            with lock:
                answers[status] = answers.get(status, 0) + 1

    threads = [threading.Thread(target=client, args=(k,)) for k in range(40)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert sum(answers.values()) == 1000
    assert answers.get(400, 0) == 200, answers  # every malformed one refused
    assert answers.get(200, 0) >= 1 and set(answers) <= {200, 400, 409}, answers  # the rest rendered or overtaken
    assert viewer.get("/api/state")[0] == 200
    after = viewer.rss_kib()
    assert after < before + 200 * 1024, (before, after)  # bounded: no queue of frames, no leak per request


def test_a_port_in_use_is_one_error_line_and_another_host_is_warned_about(viewer):
    port = viewer.url.rsplit(":", 1)[1]
    busy = subprocess.run([SOMBRA, "view", SMOKE, "--port", port], capture_output=True, text=True, timeout=120)
    assert busy.returncode == 1 and busy.stdout == ""
    assert busy.stderr.strip().splitlines() == ["sombra: error: --port: cannot listen on 127.0.0.1:" + port +
                                                " (in use, or not an address of this machine)"]
    with _started(SMOKE, "--quiet", "--host", "0.0.0.0") as v:
        assert v.get("/api/state")[0] == 200
    assert "warning: --host 0.0.0.0" in v.process.stderr.read()


class _started:
    def __init__(self, *args):
        self.viewer = Viewer(*args)

    def __enter__(self):
        return self.viewer

    def __exit__(self, *exc):
        self.viewer.close()


def test_a_volume_file_is_viewed_with_its_fitted_scene():
    with _started(os.path.join(ROOT, "data", "volumes", "cloud_shape_128.json"), "--quiet") as v:
        state = json.loads(v.get("/api/state")[1])
        assert state["lights"][0]["type"] == "directional"
        reply = frame(v)
        assert reply["width"] == 48
        status, text = v.post("/api/scene", {"options": dict(SMALL)})
        saved = json.loads(text)
        assert status == 200 and saved["volumes"][0]["file"] == os.path.join(ROOT, "data", "volumes", "cloud_shape_128.json")
        assert saved["render"] == {"dsm_resolution": 64} and saved["image"] == {"width": 48, "height": 48}
