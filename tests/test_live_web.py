"""The live view's hub and web app: what is served, the update stream, the frames with arrows.

App-level tests use starlette's TestClient (the stream is read once the hub is
closed: the TestClient returns whole bodies); the served tests run the real
uvicorn server on 127.0.0.1 and read the stream as it arrives, every socket
wait bounded. The replay of a simulated trial through ``live_updates`` checks
the streamed estimates against the simulator's ground truth.
"""

from __future__ import annotations

import http.client
import json
import threading
import time
import warnings
from urllib.parse import urlsplit

import cv2
import numpy as np
import pytest
from helpers import grid, render_blobs

from benchmarks.live_browser import replay_into, simulated_trial
from liquidtouch.errors import OutputError
from liquidtouch.live.hub import ARROW_SCALE, ZOOM_BELOW_PX, LiveHub
from liquidtouch.live.web import create_app, start_server

with warnings.catch_warnings():  # starlette 1.x prefers httpx2; httpx is what the test extra has
    warnings.simplefilter("ignore")
    from starlette.testclient import TestClient


def parse_events(text: str) -> list[tuple[str, str, str | None]]:
    """(event, data, id) of each server-sent event in ``text`` (comments and retry skipped)."""
    events = []
    for block in text.split("\n\n"):
        fields: dict[str, str] = {}
        for line in block.splitlines():
            if line and not line.startswith(":"):
                key, _, value = line.partition(": ")
                fields[key] = value
        if "event" in fields:
            events.append((fields["event"], fields.get("data", ""), fields.get("id")))
    return events


def update(i: int, **extra) -> dict:
    return {
        "t_s": 0.1 * i,
        "phase": "decay",
        "decay_rate": np.float64(0.2),
        "decay_rate_std": float("nan"),
        "angular_frequency": 14.0,
        "final": False,
        "signal": {"t_s": np.arange(3.0), "u": [0.0, 1.0, np.nan], "fit": [None, 1.0, 2.0]},
        **extra,
    }


def test_page_is_self_contained_and_nothing_else_is_served() -> None:
    app = create_app(LiveHub())
    paths = {route.path for route in app.routes}
    assert paths == {"/", "/stream", "/frame/{sensor}.jpg"}
    client = TestClient(app)
    page = client.get("/")
    assert page.status_code == 200 and page.headers["content-type"].startswith("text/html")
    assert "default-src 'none'" in page.headers["content-security-policy"]
    html = page.text
    # nothing is fetched from elsewhere: no external script, style, font or image
    assert "<link" not in html and "@import" not in html and "url(" not in html
    assert "src=" not in html.replace("img.src = `frame/", "")
    assert html.count("http") == html.count('"http://www.w3.org/2000/svg"')  # the SVG namespace
    for path in ("/index.html", "/static/live.html", "/frame/left.png", "/frame/", "/../etc"):
        assert client.get(path).status_code == 404, path
    assert client.get("/frame/left.jpg").status_code == 404  # no such sensor (yet)
    assert client.post("/").status_code == 405
    assert client.post("/stream").status_code == 405
    assert client.head("/").status_code == 405  # as docs/formats.md says: GET only
    assert client.head("/frame/left.jpg").status_code == 405


def test_a_browser_closing_its_page_is_not_an_error(caplog) -> None:
    """asyncio logged "socket.send() raised exception." ×7 (a WARNING) when a browser left."""
    import logging

    with caplog.at_level(logging.DEBUG):
        logging.getLogger("asyncio").warning("socket.send() raised exception.")
        logging.getLogger("asyncio").warning("something else")
    warnings = [r.getMessage() for r in caplog.records if r.levelno >= logging.WARNING]
    assert warnings == ["something else"]
    assert any("browser went away" in r.getMessage() for r in caplog.records)


def test_stream_sends_history_then_new_updates_then_end() -> None:
    hub = LiveHub()
    for i in range(3):
        hub.publish(update(i))

    def later() -> None:
        time.sleep(0.3)
        hub.publish(update(3, final=True, phase="done", stopped_because="end_of_stream"))
        hub.close()

    thread = threading.Thread(target=later)
    thread.start()
    with TestClient(create_app(hub)) as client:
        body = client.get("/stream").text
    thread.join(5)
    events = parse_events(body)
    assert [e[0] for e in events] == ["update"] * 4 + ["end"]
    assert [e[2] for e in events[:4]] == ["1", "2", "3", "4"]
    updates = [json.loads(e[1]) for e in events[:4]]
    assert [u["t_s"] for u in updates] == pytest.approx([0.0, 0.1, 0.2, 0.3])
    assert updates[0]["decay_rate_std"] is None  # NaN is sent as null (JSON has no NaN)
    assert updates[-1]["final"] and updates[-1]["stopped_because"] == "end_of_stream"
    # the history keeps the signal of the newest update only (the plot needs the current one)
    kept = [json.loads(text) for _, text in hub.updates_since(0)[0]]
    assert ["signal" in u for u in kept] == [False, False, False, True]
    assert updates[0].keys() == kept[0].keys()  # what a late browser gets first
    assert updates[-1]["signal"] == {
        "t_s": [0.0, 1.0, 2.0],
        "u": [0.0, 1.0, None],
        "fit": [None, 1.0, 2.0],
    }

    # a browser that reconnects resumes after the last update it saw
    with TestClient(create_app(hub)) as client:
        resumed = parse_events(client.get("/stream", headers={"Last-Event-ID": "2"}).text)
    assert [(e[0], e[2]) for e in resumed] == [("update", "3"), ("update", "4"), ("end", None)]


def test_app_state_lifespan_and_log(caplog: pytest.LogCaptureFixture) -> None:
    """Module-level endpoints over ``app.state``; the lifespan and the clients are logged."""
    from liquidtouch.live import web

    hub = LiveHub()
    app = create_app(hub)
    assert app.state.hub is hub and app.state.readers == 0 and not app.state.stopping.is_set()
    assert {route.endpoint for route in app.routes} == {web.page, web.events, web.frame}
    hub.publish(update(0))
    hub.close()
    with caplog.at_level("INFO", logger="liquidtouch.live.web"), TestClient(app) as client:
        events = parse_events(client.get("/stream").text)
    assert [e[0] for e in events] == ["update", "end"]
    assert app.state.stopping.is_set() and app.state.readers == 0  # the shutdown ended streams
    messages = [r.getMessage() for r in caplog.records if r.name == "liquidtouch.live.web"]
    assert messages[0] == "live view: serving" and messages[-1].startswith("live view: stopped")
    assert any("connected (1 watching)" in m for m in messages)
    assert any("disconnected (0 watching)" in m for m in messages)


def test_history_is_thinned_not_cut() -> None:
    hub = LiveHub(max_updates=10)
    for i in range(100):
        # the newest signal (update 42) stays even though later updates carry none
        hub.publish({"t_s": float(i), "signal": {"u": [i]} if i in (3, 42) else None})
    items, closed = hub.updates_since(0)
    updates = [json.loads(text) for _, text in items]
    times = [u["t_s"] for u in updates]
    assert not closed and len(items) <= 11
    assert times[0] == 0.0 and times[-1] == 99.0  # the plots still span the whole trial
    assert times == sorted(times) and [s for s, _ in items] == sorted(s for s, _ in items)
    assert [u["signal"] for u in updates if "signal" in u] == [{"u": [42]}]
    with pytest.raises(TypeError):
        hub.publish([1, 2])  # type: ignore[arg-type]


def green(image: np.ndarray) -> np.ndarray:
    """Mask of the arrows' green pixels in a decoded BGR frame."""
    b, g, r = (image[..., i].astype(int) for i in range(3))
    return (g - np.maximum(b, r)) > 60


def test_frame_is_a_jpeg_with_displacement_arrows() -> None:
    reference = grid()
    shift = np.array([2.0, -1.0])  # px: every marker moved by this
    image = render_blobs(reference + shift)
    hub = LiveHub()
    hub.publish_frame("left", image, reference, reference + shift)
    client = TestClient(create_app(hub))
    response = client.get("/frame/left.jpg")
    assert response.status_code == 200 and response.headers["content-type"] == "image/jpeg"
    decoded = cv2.imdecode(np.frombuffer(response.content, np.uint8), cv2.IMREAD_COLOR)
    assert image.shape[1] < ZOOM_BELOW_PX  # a small frame is shown zoomed ×2
    assert decoded.shape == (2 * image.shape[0], 2 * image.shape[1], 3)
    mask = green(decoded)

    def zoomed(points_px: np.ndarray) -> np.ndarray:
        return np.rint(2 * (points_px + 0.5) - 0.5).astype(int)

    # each arrow runs from the reference to reference + ARROW_SCALE × shift: its middle is green
    middle = zoomed(reference + 0.5 * ARROW_SCALE * shift)
    near = [mask[y - 1 : y + 2, x - 1 : x + 2].any() for x, y in middle]
    assert np.mean(near) > 0.9
    # and nowhere far from an arrow: the rest of the image is the grey frame
    far = zoomed(reference - 4 * shift)
    assert not any(mask[y, x] for x, y in far)
    large = np.zeros((ZOOM_BELOW_PX, ZOOM_BELOW_PX), np.uint8)
    hub.publish_frame("big", large, reference, reference + shift)
    big = cv2.imdecode(np.frombuffer(client.get("/frame/big.jpg").content, np.uint8), 1)
    assert big.shape == (*large.shape, 3) and green(big).sum() > 0

    # the same markers at rest: no arrow of any length, only dots at the markers
    hub.publish_frame("left", image, reference, reference)
    hub.frame_interval_s = 0.0
    rest = cv2.imdecode(np.frombuffer(client.get("/frame/left.jpg").content, np.uint8), 1)
    assert green(rest).sum() < 0.2 * mask.sum()


def test_frames_are_encoded_lazily_at_most_every_interval() -> None:
    hub = LiveHub(frame_interval_s=60.0)
    image = np.full((40, 50), 128, np.uint8)
    hub.publish_frame("left", image)
    first = hub.frame_jpeg("left")
    hub.publish_frame("left", np.zeros((40, 50, 3), np.uint8))  # BGR works too
    assert hub.frame_versions() == {"left": 2}
    assert hub.frame_jpeg("left") == first  # within the interval: the last encoding
    hub.frame_interval_s = 0.0
    assert hub.frame_jpeg("left") != first
    assert hub.frame_jpeg("right") is None
    with pytest.raises(ValueError, match="uint8"):
        hub.publish_frame("left", image.astype(float))


def read_stream(url: str, until: str, timeout_s: float = 30.0) -> list[tuple[str, str, str | None]]:
    """The events of ``url`` + ``stream`` up to and including the first ``until`` event."""
    parts = urlsplit(url)
    connection = http.client.HTTPConnection(parts.hostname, parts.port, timeout=timeout_s)
    try:
        connection.request("GET", "/stream")
        response = connection.getresponse()
        assert response.status == 200
        assert response.getheader("content-type").startswith("text/event-stream")
        text, deadline = "", time.monotonic() + timeout_s
        while time.monotonic() < deadline:
            line = response.readline().decode()
            if not line:
                break
            text += line
            if line == "\n" and any(e[0] == until for e in parse_events(text)):
                break
        return parse_events(text)
    finally:
        connection.close()


def test_served_on_loopback_streams_as_it_goes_and_stops() -> None:
    hub = LiveHub()
    with start_server(hub) as server:
        parts = urlsplit(server.url)
        assert parts.hostname == "127.0.0.1" and parts.port > 0
        got: list = []
        reader = threading.Thread(target=lambda: got.extend(read_stream(server.url, "end")))
        reader.start()
        deadline = time.monotonic() + 10
        while server.readers < 1 and time.monotonic() < deadline:
            time.sleep(0.01)
        assert server.readers == 1
        hub.publish(update(0))
        hub.publish_frame("left", np.full((30, 40), 90, np.uint8))
        time.sleep(0.3)
        hub.close()
        reader.join(10)
        assert [e[0] for e in got] == ["update", "frames", "end"]
        assert json.loads(got[1][1]) == {"left": 1}
        # a page from another Host (DNS rebinding) is refused on loopback
        connection = http.client.HTTPConnection("127.0.0.1", parts.port, timeout=10)
        connection.request("GET", "/", headers={"Host": "evil.example"})
        assert connection.getresponse().status == 400
        connection.close()
        with pytest.raises(OutputError, match="cannot serve"):
            start_server(hub, port=parts.port)  # the port is taken
    # stop() ends the server within its bound, even with a stream open: the browser gets
    # what was published before the stop, then the end (not a broken connection)
    hub2 = LiveHub()
    server = start_server(hub2)
    got2: list = []
    reader = threading.Thread(target=lambda: got2.extend(read_stream(server.url, "end", 20)))
    reader.start()
    time.sleep(0.3)
    hub2.publish(update(7))
    started = time.monotonic()
    server.stop()
    reader.join(10)
    assert time.monotonic() - started < 5 and not reader.is_alive()
    assert [(e[0], e[2]) for e in got2] == [("update", "1"), ("end", None)]
    with pytest.raises(OSError):
        http.client.HTTPConnection("127.0.0.1", urlsplit(server.url).port, timeout=2).connect()


@pytest.fixture(scope="module")
def trial(tmp_path_factory):
    return simulated_trial(tmp_path_factory.mktemp("live_web"))


def test_a_replayed_trial_streams_estimates_near_the_truth(trial) -> None:
    trial_dir, model_path, meta = trial
    hub = LiveHub()
    with start_server(hub) as server:
        got: list = []
        reader = threading.Thread(target=lambda: got.extend(read_stream(server.url, "end", 120)))
        reader.start()
        published = replay_into(hub, trial_dir, model=model_path, realtime=False)
        reader.join(120)
    updates = [json.loads(data) for event, data, _ in got if event == "update"]
    frames = [json.loads(data) for event, data, _ in got if event == "frames"]
    assert len(updates) == len(published) > 3
    final = updates[-1]
    assert final["final"] and final["phase"] == "done" and final["stopped_because"]
    assert final == json.loads(json.dumps(published[-1], allow_nan=True).replace("NaN", "null"))
    # the estimates the page shows, against the simulator's ground truth
    assert final["angular_frequency"] == pytest.approx(meta["true_angular_frequency"], rel=0.01)
    assert abs(final["predicted_height_mm"] - meta["height_mm"]) < 2.0
    assert 0 < final["predicted_height_mm_std"] < 2.0
    assert len(final["signal"]["u"]) > 50 and any(v is not None for v in final["signal"]["fit"])
    assert set(frames[-1]) == set(meta["sensor_names"])
