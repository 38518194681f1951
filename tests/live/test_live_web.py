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

from liquidtouch.errors import OutputError
from liquidtouch.live.hub import (
    ARROW_SCALE,
    MAX_FIT_POINTS,
    SIGNAL_KEEP_S,
    ZOOM_BELOW_PX,
    LiveHub,
)
from liquidtouch.live.web import create_app, start_server
from liquidtouch.testing.live_page import replay_into, simulated_trial

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
    # each update carries only what is new of the signal: the first a snapshot, then deltas
    assert updates[0]["signal"] == {
        "from_t_s": None,
        "t_s": [0.0, 1.0, 2.0],
        "u": [0.0, 1.0, None],
        "fit": {"t_s": [1.0, 2.0], "u": [1.0, 2.0]},
    }
    # a late browser gets the history without signals and the kept signal on the newest
    kept = [json.loads(text) for _, text in hub.updates_since(0)[0]]
    assert [u.keys() for u in kept] == [u.keys() for u in updates]
    late = [json.loads(text) for _, text in hub.updates_since(-5)[0]]
    assert ["signal" in u for u in late] == [False, False, False, True]
    assert late[-1]["signal"]["from_t_s"] is None and late[-1]["signal"]["t_s"] == [0.0, 1.0, 2.0]

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
        signal = {"t_s": [float(i)], "u": [float(i)]} if i in (3, 42) else None
        hub.publish({"t_s": float(i), "signal": signal})
    items, closed = hub.updates_since(0)
    updates = [json.loads(text) for _, text in items]
    times = [u["t_s"] for u in updates]
    assert not closed and len(items) <= 11
    assert times[0] == 0.0 and times[-1] == 99.0  # the plots still span the whole trial
    assert times == sorted(times) and [s for s, _ in items] == sorted(s for s, _ in items)
    # the reader missed updates: the newest signal (update 42's) comes as a snapshot
    assert [u["signal"] for u in updates if "signal" in u] == [
        {"from_t_s": None, "t_s": [42.0], "u": [42.0], "fit": None}
    ]
    with pytest.raises(TypeError):
        hub.publish([1, 2])  # type: ignore[arg-type]


def _signal(t0: float, t1: float, origin: float = 0.0, fps: float = 30.0) -> dict:
    """A decaying oscillation sampled over [t0, t1] [s] (decay clock) with a fit past 0."""
    t = np.arange(t0, t1, 1 / fps)
    u = np.exp(-0.5 * np.maximum(t, 0)) * np.sin(12 * t)
    fit = np.where(t >= 0, u, np.nan)
    return {"t_s": t, "u": u, "fit": fit}


def test_updates_carry_only_the_new_signal_and_a_late_browser_a_bounded_snapshot() -> None:
    """Update sizes do not grow with the stream; what a browser rebuilds is the signal."""
    hub = LiveHub()
    sizes = []
    shown_t: list[float] = []  # what a browser that keeps up has, applying each delta
    shown_u: list[float] = []
    for k in range(240):  # 60 s of refreshes every 0.25 s, the window growing from 1 s
        now = 1.0 + 0.25 * k
        hub.publish({"t_s": now, "elapsed_s": now + 5.0, "signal": _signal(-2.0, now)})
        [(_, text)] = hub.updates_since(k)[0]
        sizes.append(len(text))
        signal = json.loads(text)["signal"]
        start = -np.inf if signal["from_t_s"] is None else signal["from_t_s"]
        keep = [i for i, t in enumerate(shown_t) if t < start]
        shown_t = [shown_t[i] for i in keep] + signal["t_s"]
        shown_u = [shown_u[i] for i in keep] + signal["u"]
    assert max(sizes[200:]) < 1.1 * max(sizes[40:60])  # not growing with the signal
    last = _signal(-2.0, 1.0 + 0.25 * 239)
    assert np.allclose(shown_t, last["t_s"], atol=1e-4)  # 62 s: the browser trims to 60 s
    assert np.allclose(shown_u, last["u"], atol=1e-4)
    # a new decay clock (a new push): a snapshot, bounded to the kept span
    hub.publish({"t_s": 1.0, "elapsed_s": 100.0, "signal": _signal(-90.0, 1.0)})
    signal = json.loads(hub.updates_since(240)[0][-1][1])["signal"]
    assert signal["from_t_s"] is None
    assert signal["t_s"][0] >= signal["t_s"][-1] - SIGNAL_KEEP_S - 1e-3
    assert len(signal["fit"]["t_s"]) <= MAX_FIT_POINTS
    # a late browser: the history without signals, then the kept signal once
    late = [json.loads(text) for _, text in hub.updates_since(-1)[0]]
    assert sum("signal" in u for u in late) == 1 and late[-1]["signal"]["from_t_s"] is None


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
    sent = json.loads(json.dumps(published[-1], allow_nan=True).replace("NaN", "null"))
    assert {k: v for k, v in final.items() if k != "signal"} == {
        k: v for k, v in sent.items() if k != "signal"
    }
    # the signal a browser rebuilds from the updates' deltas is the final update's
    t_s: list[float] = []
    u: list[float | None] = []
    fit = None
    for update_ in updates:
        delta = update_.get("signal")
        if delta is not None:
            start = -np.inf if delta["from_t_s"] is None else delta["from_t_s"]
            keep = [i for i, t in enumerate(t_s) if t < start]
            t_s = [t_s[i] for i in keep] + delta["t_s"]
            u = [u[i] for i in keep] + delta["u"]
            fit = delta.get("fit", fit)
    # over the final signal's span (the browser may keep older samples of the same clock),
    # up to the small moves of earlier refreshes' samples (a clock shifted by < 1 % of a
    # sample, the filter's edge): what the page shows is the final signal
    inside = np.array(t_s) >= sent["signal"]["t_s"][0] - 0.02
    shown_t, final_t = np.array(t_s)[inside], np.array(sent["signal"]["t_s"])
    assert shown_t.shape == final_t.shape and np.abs(shown_t - final_t).max() < 0.005
    shown_u, final_u = np.array(u, float)[inside], np.array(sent["signal"]["u"], float)
    assert np.sqrt(np.nanmean((shown_u - final_u) ** 2)) < 0.05 * np.nanstd(final_u)
    assert len(u) > 50 and fit is not None and len(fit["u"]) > 50
    assert set(frames[-1]) == set(meta["sensor_names"])
