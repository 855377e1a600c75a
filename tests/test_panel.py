"""The live panel (hydrohil panel / hil --panel) through its HTTP API and side channel, with real processes.

The browser end-to-end tests are in test_panel_browser.py."""

import json
import os
import signal
import socket
import time
import urllib.error
import urllib.request

import numpy as np
import pytest

from conftest import EXAMPLES, PanelProcess, hh_command
from hydrohil.simulation.outputs import read_csv_columns
from hydrohil.hil.session import replay_session
from hydrohil.simulation.steering import read_events
from hydrohil.simulation.rig import run_rig
from hydrohil.simulation.scenario import load_scenario

FIG11 = EXAMPLES / "fig11_p_control.toml"


@pytest.fixture(params=["python", "c"])
def lockstep_panel(tmp_path, request):
    """A lock-step panel session on either plant (``hydrohil panel --plant python|c``)."""
    p = PanelProcess(tmp_path / "panel", "--lockstep", "--plant", request.param)
    yield p
    p.close()


def _record(p, steer, steps_between=400):
    """Start a recording, apply ``steer`` (a list of API bodies) each after ``steps_between`` more plant steps,
    stop it; returns (recording entry, answers)."""
    answers = []
    p.api("api/record/start", {})
    for body in steer:
        k = p.api("api/state")["counters"]["steps"]
        p.wait_steps(k + steps_between)
        answers.append(p.api("api/steer", body))
    k = p.api("api/state")["counters"]["steps"]
    p.wait_steps(k + steps_between)
    rec = p.api("api/record/stop", {})
    return rec, answers


@pytest.mark.slow
def test_steered_lockstep_session_replays_offline_bit_for_bit(lockstep_panel, tmp_path):
    """A panel session with every kind of change (tunables, a fault on and off, gains, a held reference, a
    reset) replays offline — plant and controller, from the event logs — to the same result bit for bit: on the
    Python plant and on the standalone C plant (its side channel, steering, session folder and recordings)."""
    p = lockstep_panel
    p.wait_steps(200)
    steer = [{"op": "set", "name": "mass", "value": 150.0},
             {"op": "gains", "kp": 90.0},
             {"op": "fault_on", "fault": {"type": "hose_burst", "line": 2, "section": 0.5}},
             {"op": "set", "name": "supply_pressure", "value": 5e6},
             {"op": "fault_off", "slot": 0},
             {"op": "reference", "value": 0.08},
             {"op": "fault_on", "fault": {"type": "sensor_noise", "sensor": "p1", "std": 2e4}},
             {"op": "set", "name": "friction_scale", "value": 2.0},
             {"op": "reset"}]
    rec, answers = _record(p, steer)
    assert [a["k"] for a in answers] == sorted(a["k"] for a in answers)
    assert answers[2]["slot"] == 0
    ended = p.api("api/run/stop", {})
    assert ended["exit_codes"] == {"plant": 0, "controller": 0} and ended["verdict"]["valid"]
    session = p.session
    plant_ev, ctl_ev = read_events(session / "events.jsonl", "plant"), read_events(session / "controller_events.jsonl",
                                                                                     "controller")
    assert sum(map(len, plant_ev.values())) == 7 and sum(map(len, ctl_ev.values())) == 2
    log = read_csv_columns(session / "recordings" / rec["name"] / "plant_log.csv")
    from hydrohil.core import shape
    rec_timing = json.loads((session / "recordings" / rec["name"] / "timing.json").read_text())
    assert list(rec_timing) == list(shape.timing_keys("lockstep", recording=True))     # either plant's, in order
    assert rec_timing["recorded_steps"] == [rec["k0"], rec["k1"]] and rec_timing["steps"] == len(log["k"])
    sc = load_scenario(session / "scenario.toml")
    k1 = int(log["k"][-1])
    off = run_rig(sc, events=plant_ev, controller_events=ctl_ev, steps=k1)
    ks = log["k"].astype(int)
    for c in ("xp", "p1", "p2", "xs", "vp"):
        assert np.array_equal(log[c], off.column(c)[ks]), c
    assert np.array_equal(log["u"], off.column("u")[ks - 1])     # (a plant log's row k: the command of step k-1)
    assert np.array_equal(log["encoder"] * 1e-6, off.column("x_meas")[ks])
    assert np.array_equal(log["p1_meas"], off.column("p1_meas")[ks])       # the noise fault's draws too
    # without the events the offline run is another run: the test can fail
    plain = run_rig(sc, steps=k1)
    assert not np.array_equal(log["xp"], plain.column("xp")[ks])
    # the panel's replay check of the recording (commands + plant events)
    cmp = json.loads((session / "recordings" / rec["name"] / "comparison.json").read_text())
    assert cmp["replay_xp_max_abs"] == 0.0 and cmp["replay_p1_max_abs"] == 0.0


@pytest.mark.parametrize("plant", ["python", "c"])
def test_realtime_session_recording_is_a_run_folder_and_replays(tmp_path, plant):
    """Real time (whatever the timing), on either plant: the recording is a complete run folder; the session's
    applied commands and events replay its states bit for bit; a supply change shows in the supply transducer's
    column from the step it was applied at."""
    p = PanelProcess(tmp_path / "panel", "--plant", plant)
    try:
        p.wait_steps(400)
        rec, (ans,) = _record(p, [{"op": "set", "name": "supply_pressure", "value": 3e6}])
        state = p.api("api/state")
        assert state["tunables"]["supply_pressure"] == 3e6 and state["events"][-1]["k"] == ans["k"]
        ended = p.api("api/run/stop", {})
        assert ended["exit_codes"]["plant"] in (0, 3) and ended["exit_codes"]["controller"] == 0   # 3: INVALID
        assert p.api("api/state")["running"] is False
    finally:
        p.close()
    folder = p.session / "recordings" / rec["name"]
    for f in ("plant_log.csv", "timing.json", "events.jsonl", "scenario.toml"):
        assert (folder / f).is_file(), f
    timing = json.loads((folder / "timing.json").read_text())
    assert timing["steps"] == rec["steps"] and timing["verdict"]["verdict"] in ("VALID", "INVALID")
    log = read_csv_columns(folder / "plant_log.csv")
    assert np.array_equal(log["k"], np.arange(rec["k0"] + 1, rec["k1"] + 1))   # every step, none twice
    ps = log["ps_meas"]
    before, after = log["k"] < ans["k"], log["k"] > ans["k"]
    assert np.all(ps[before] > 60e5) and np.all(np.abs(ps[after] - 30e5) < 0.1e5)
    sc = load_scenario(p.session / "scenario.toml")
    rep = replay_session(sc, p.session, steps=rec["k1"])
    ks = log["k"].astype(int)
    for c in ("xp", "p1", "p2", "xs"):
        assert np.array_equal(rep[c][ks], log[c]), c
    timing_session = json.loads((p.session / "timing.json").read_text())
    assert timing_session["steps"] >= rec["k1"] and timing_session["stop_signal"] is None


def test_bad_changes_are_refused_with_the_field_named(tmp_path):
    p = PanelProcess(tmp_path / "panel", "--lockstep")
    try:
        p.wait_steps(50)
        for body, text in (({"op": "set", "name": "mass", "value": -3}, "mass must be in [0.1, 100000] kg"),
                           ({"op": "set", "name": "stiffness", "value": 1}, "name"),
                           ({"op": "fault_on", "fault": {"type": "hose_burst", "line": 3}}, "hose_burst.line"),
                           ({"op": "fault_on", "fault": {"type": "no_such"}}, "fault"),
                           ({"op": "fault_off", "slot": 5}, "no active fault in slot 5"),
                           ({"op": "gains", "kp": -1}, "kp")):
            with pytest.raises(urllib.error.HTTPError) as e:
                p.api("api/steer", body)
            assert e.value.code == 400
            assert text in json.loads(e.value.read())["error"], body
        p.api("api/run/stop", {})
    finally:
        p.close()
    assert not (p.session / "events.jsonl").read_text().strip()        # nothing refused was applied


def _http(url, headers=None):
    try:
        with urllib.request.urlopen(urllib.request.Request(url, headers=headers or {}), timeout=30) as r:
            return r.status
    except urllib.error.HTTPError as e:
        return e.code


def _ws_handshake(port, path, origin=None, host="127.0.0.1"):
    """Status line of a raw WebSocket upgrade request (what a browser sends)."""
    import base64
    key = base64.b64encode(os.urandom(16)).decode()
    lines = [f"GET {path} HTTP/1.1", f"Host: {host}:{port}", "Upgrade: websocket", "Connection: Upgrade",
             f"Sec-WebSocket-Key: {key}", "Sec-WebSocket-Version: 13"] + ([f"Origin: {origin}"] if origin else [])
    with socket.create_connection(("127.0.0.1", port), timeout=30) as s:
        s.sendall(("\r\n".join(lines) + "\r\n\r\n").encode())
        return int(s.recv(200).split(b" ")[1])


@pytest.mark.slow
def test_remote_access_needs_the_token_and_the_panels_origin(tmp_path):
    p = PanelProcess(tmp_path / "panel", "--lockstep", "--allow-remote", "--host", "127.0.0.1")
    try:
        base, query = p.url.split("?")
        token = query.split("=", 1)[1]
        port = int(base.rstrip("/").rsplit(":", 1)[1])
        assert len(token) >= 20
        assert _http(base) == 403 and _http(base + "api/state") == 403
        assert _http(base + "api/state?token=wrong" + token[5:]) == 403
        assert _http(base + "?" + query) == 200 and _http(base + "api/state", {"X-Hydrohil-Token": token}) == 200
        assert _ws_handshake(port, "/ws") == 403                                  # no token
        assert _ws_handshake(port, "/ws?" + query, origin="http://evil.example") == 403
        assert _ws_handshake(port, "/ws?" + query, origin=f"http://127.0.0.1:{port}") == 101
    finally:
        p.close()


def test_loopback_panel_refuses_foreign_hosts_and_origins(tmp_path):
    p = PanelProcess(tmp_path / "panel", "--lockstep")
    try:
        port = int(p.url.rstrip("/").rsplit(":", 1)[1])
        assert _http(p.url + "api/state") == 200
        assert _http(p.url + "api/state", {"Host": f"attacker.example:{port}"}) == 403       # DNS rebinding
        assert _ws_handshake(port, "/ws", origin="http://attacker.example") == 403
        assert _ws_handshake(port, "/ws", origin=f"http://127.0.0.1:{port}") == 101
    finally:
        p.close()


@pytest.mark.slow
def test_a_stalled_panel_costs_the_plant_telemetry_not_steps(tmp_path):
    """The panel process frozen (SIGSTOP): the plant goes on stepping (lock-step: as fast as the controller
    answers); its telemetry is dropped (the kernel drops what the frozen panel's buffer cannot hold; the
    plant's sends never block) and the panel, thawed, counts the steps it never saw."""
    p = PanelProcess(tmp_path / "panel", "--lockstep")
    try:
        p.wait_steps(100)
        p.child.proc.send_signal(signal.SIGSTOP)
        try:
            before = _steps_done(p.session)
            _wait_file_growth(p.session / "commands.f64", before + 40_000)     # the plant stepped on (20 s of
                                                                                # telemetry > the panel's buffer)
        finally:
            p.child.proc.send_signal(signal.SIGCONT)
        s = p.wait_steps(before + 45_000)
        assert s["counters"]["telemetry_lost_steps"] > 0
        p.api("api/run/stop", {})
    finally:
        p.close()


def _steps_done(session):
    return (session / "commands.f64").stat().st_size // 8 if (session / "commands.f64").exists() else 0


def _wait_file_growth(path, n_steps, timeout=120):
    import time
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        if path.exists() and path.stat().st_size // 8 >= n_steps:
            return
        time.sleep(0.05)
    raise AssertionError(f"{path} did not reach {n_steps} steps")


def _hil_panel(scenario, out, *args):
    """``hydrohil hil SCENARIO --lockstep --panel`` started, waited for until its plant's telemetry reached the
    panel (it runs); returns (the process, post(body) -> the answer of /api/steer)."""
    import urllib.request as ur
    from hydrohil.hil.processes import Child
    ch = Child(hh_command("hil", scenario, "--out", out, "--lockstep", "--panel", "--panel-port", "0", *args), "hil")
    url = ch.wait_line("PANEL ", 120)

    def post(body):
        req = ur.Request(url + "api/steer", data=json.dumps(body).encode(), headers={"Content-Type": "application/json"})
        with ur.urlopen(req, timeout=60) as r:
            return json.loads(r.read())
    end = time.monotonic() + 120
    while time.monotonic() < end:                 # the plant's telemetry reached the panel: it runs
        with ur.urlopen(url + "api/state", timeout=60) as r:
            if json.loads(r.read())["counters"]["steps"] > 100:
                break
        time.sleep(0.05)
    return ch, post


@pytest.mark.slow
@pytest.mark.parametrize("plant", ["python", "c"])
def test_hil_panel_run_replays_its_changes_offline(tmp_path, plant):
    """hydrohil hil --panel --lockstep, on either plant: changes made while it runs are in the run's event logs
    and the offline comparison replays them: the HIL and offline positions are equal bit for bit."""
    import shutil
    scen = tmp_path / "long.toml"
    shutil.copy(FIG11, scen)
    text = scen.read_text()
    assert "duration = 6.0" in text
    scen.write_text(text.replace("duration = 6.0", "duration = 60.0"))
    out = tmp_path / "run"
    ch, post = _hil_panel(scen, out, "--plant", plant)
    a = post({"op": "set", "name": "mass", "value": 200.0})
    b = post({"op": "gains", "kp": 70.0})
    assert ch.wait(600) == 0, ch.stderr()
    cmp = json.loads((out / "comparison.json").read_text())
    assert cmp["xp_max_mm"] == 0.0 and cmp["replay_xp_max_abs_m"] == 0.0
    assert read_events(out / "events.jsonl", "plant")[a["k"]][0].value == 200.0
    assert read_events(out / "controller_events.jsonl", "controller")[b["k"]][0].kp == 70.0


def test_cross_site_posts_are_refused(tmp_path):
    """A page of another site in the user's browser cannot steer the rig: a POST with a foreign Origin, a
    cross-site fetch, or a form/no-cors body (not JSON) is refused; nothing is applied."""
    p = PanelProcess(tmp_path / "panel", "--lockstep")
    try:
        p.wait_steps(50)
        body = json.dumps({"op": "set", "name": "supply_pressure", "value": 1e7}).encode()
        url = p.url + "api/steer"
        port = int(p.url.rstrip("/").rsplit(":", 1)[1])
        for headers, code in (({"Content-Type": "application/json", "Origin": "http://evil.example"}, 403),
                              ({"Content-Type": "application/json", "Sec-Fetch-Site": "cross-site"}, 403),
                              ({"Content-Type": "text/plain"}, 415),
                              ({"Content-Type": "application/json", "Origin": f"http://127.0.0.1:{port}"}, 200)):
            req = urllib.request.Request(url, data=body, headers=headers, method="POST")
            try:
                with urllib.request.urlopen(req, timeout=60) as r:
                    got = r.status
            except urllib.error.HTTPError as e:
                got = e.code
            assert got == code, headers
        assert len(p.api("api/state")["events"]) == 1          # only the same-origin JSON request
    finally:
        p.close()


def test_side_channel_applies_a_retried_message_once():
    """The panel resends a change until it is answered: copies that arrive together are taken once, and a
    copy after the answer gets the same answer again."""
    from hydrohil.hil.sidechannel import PLANT_COLUMNS, ROLE_PLANT, SideChannel
    panel = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    panel.bind(("127.0.0.1", 0))
    panel.settimeout(30)
    side = SideChannel(panel.getsockname(), ROLE_PLANT, PLANT_COLUMNS)
    assert json.loads(panel.recv(65536))["hello"] == "plant"
    msg = json.dumps({"id": 7, "op": "reset"}).encode()
    for _ in range(3):
        panel.sendto(msg, side.address)
    got = []
    while len(got) < 1:                       # the three copies arrive (loopback): one is taken
        got += side.poll()
    assert got == [{"id": 7, "op": "reset"}] and side.poll() == []
    side.answer(got[0], k=12)
    assert json.loads(panel.recv(65536)) == {"ack": 7, "k": 12}
    panel.sendto(msg, side.address)              # a late copy: answered again, not taken
    panel.settimeout(0.01)
    for _ in range(10_000):
        assert side.poll() == []
        try:
            assert json.loads(panel.recv(65536)) == {"ack": 7, "k": 12}
            break
        except socket.timeout:
            continue
    else:
        raise AssertionError("the late copy was not answered")
    side.close()
    panel.close()


def test_trace_pyramid_equals_brute_force_over_laps_of_the_ring():
    """Min/max blocks of every window after the ring wrapped several times equal the extremes of the steps
    in them (nothing of an earlier lap leaks in), whatever the level."""
    from hydrohil.panel.traces import PLANT_COLUMNS, Traces
    tr = Traces(5e-4, capacity=8192)
    rng = np.random.default_rng(3)
    n = 8192 * 4 + 777
    data = rng.standard_normal((n, len(PLANT_COLUMNS)))
    checked = 0
    for i in range(0, n, 20):
        tr.add_plant(i, data[i:i + 20])
        if i % 220 == 0:
            for w in (0.05, 0.5, 3.5):
                f = tr.frame(w, None, ["xp", "p1"], 64)
                for j in range(f["n"]):
                    ks = np.arange((f["b0"] + j) * f["block"], (f["b0"] + j + 1) * f["block"])
                    ks = ks[ks <= tr.k_max]
                    for c, col in ((0, 1), (1, 5)):
                        assert f["lo"][c, j] == np.float32(data[ks, col].min())
                        assert f["hi"][c, j] == np.float32(data[ks, col].max())
                    checked += 1
    assert checked > 5000 and tr.lost == 0


@pytest.mark.slow
def test_ctrl_c_says_how_it_ended_and_a_browser_going_away_is_one_line(tmp_path):
    """Issue #25 §4: Ctrl-C ends ``hydrohil panel`` with exit code 130 (the README's) and this run's sessions
    and recordings named (not an earlier run's in the same folder); a client that disconnects mid-request (a POST whose body never comes, a WebSocket
    reset) gets one line each on stderr, never a traceback."""
    import struct
    old = tmp_path / "panel" / "session-001" / "recordings" / "rec-001"      # an earlier run's, same folder
    old.mkdir(parents=True)
    p = PanelProcess(tmp_path / "panel", "--lockstep")
    assert p.session.name == "session-002"
    try:
        p.wait_steps(50)
        rec, _ = _record(p, [])
        host, port = p.url.split("//")[1].split("/")[0].split(":")
        s = socket.create_connection((host, int(port)))
        s.sendall(f"POST /api/steer HTTP/1.1\r\nHost: {host}:{port}\r\nContent-Type: application/json\r\n"
                  f"Content-Length: 500\r\n\r\n{{\"op\": ".encode())
        s.close()
        s = socket.create_connection((host, int(port)))
        s.sendall(f"GET /ws HTTP/1.1\r\nHost: {host}:{port}\r\nUpgrade: websocket\r\nConnection: Upgrade\r\n"
                  f"Sec-WebSocket-Key: dGhlIHNhbXBsZSBub25jZQ==\r\nSec-WebSocket-Version: 13\r\n"
                  f"Origin: http://{host}:{port}\r\n\r\n".encode())
        assert b"101 Switching Protocols" in s.recv(4096)
        s.recv(1 << 16)                                      # a frame arrived: the page's stream is on
        s.setsockopt(socket.SOL_SOCKET, socket.SO_LINGER, struct.pack("ii", 1, 0))
        s.close()                                            # reset, no close frame
        deadline = time.monotonic() + 60
        while sum("went away" in ln for ln in p.child.stderr_lines) < 2:
            assert time.monotonic() < deadline, p.child.stderr_lines
            time.sleep(0.05)                                 # waiting for the panel's own lines (a handshake)
        p.child.send_signal(signal.SIGINT)
        assert p.child.wait(60) == 130
    finally:
        p.close()
    out = "".join(iter(lambda: p.child.lines.get() or "", ""))
    assert "panel stopped by SIGINT (Ctrl-C): 1 session(s) in" in out and "recordings: 1" in out
    assert str(p.session / "recordings" / rec["name"]) in out and str(old) not in out
    err = p.child.stderr()
    assert "Traceback" not in err
    lines = [ln for ln in err.splitlines() if "went away" in ln]
    assert len(lines) == 2 and any("POST /api/steer" in ln for ln in lines) and any("GET /ws" in ln for ln in lines), err


@pytest.mark.parametrize("plant", ["python", "c"])
def test_either_plant_speaks_the_side_channel_to_a_raw_panel(tmp_path, plant):
    """A panel written from docs/protocol.md alone (a UDP socket): the plant says hello, streams telemetry rows
    equal to its own plant log's, refuses bad steering with the field named, applies a change sent three times
    once (every copy gets the same answer), logs it in events.jsonl and stops when told."""
    from hydrohil.hil.processes import Child, process_command
    from hydrohil.hil.run import plant_command
    from hydrohil.hil.sidechannel import COUNTERS, HEADER, PLANT_COLUMNS, parse_batch
    panel = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    panel.bind(("127.0.0.1", 0))
    panel.settimeout(60)
    out = tmp_path / "run"
    sc = load_scenario(FIG11)
    plant_p = Child(plant_command(sc, FIG11, out, None, lockstep=True, plant=plant,
                                  extra=("--panel", f"127.0.0.1:{panel.getsockname()[1]}", "--duration", "0")), "plant")
    ctl = None
    try:
        address = plant_p.wait_line("READY ", 120)
        ctl = Child(process_command("controller", "--scenario", FIG11, "--connect", address), "controller")
        rows, answers, plant_addr = {}, {}, None

        def receive_until(done):
            nonlocal plant_addr
            while not done():
                data, plant_addr = panel.recvfrom(65536)
                if data[:4] == b"HHTM":
                    role, k0, counters, ncols, nrows, payload = parse_batch(data)
                    assert ncols == len(PLANT_COLUMNS) and len(data) == HEADER.size + COUNTERS.size + 8 * ncols * nrows
                    block = np.frombuffer(payload, dtype="<f8").reshape(nrows, ncols)
                    for i in range(nrows):
                        rows[k0 + i] = block[i]
                else:
                    msg = json.loads(data)
                    if "hello" in msg:
                        assert msg == {"hello": "plant", "columns": list(PLANT_COLUMNS)}
                    else:
                        answers.setdefault(msg["ack"], []).append(msg)

        receive_until(lambda: len(rows) >= 200)
        bad = {1: {"op": "set", "name": "mass", "value": 1e9},
               2: {"op": "fault_on", "fault": {"type": "sensor_offset", "sensor": "p9", "offset": 1.0}},
               3: {"op": "warp"}, 4: {"op": "fault_off", "slot": 40}, 7: {"op": "reset", "note": "x"},
               8: {"op": "fault_on", "fault": {"type": "packet_loss", "probability": "0.5,start=3"}}}
        panel.sendto(b"{not json", plant_addr)
        for i, body in bad.items():
            panel.sendto(json.dumps({"id": i, **body}).encode(), plant_addr)
        fault = {"id": 5, "op": "fault_on", "fault": {"type": "sensor_offset", "start": 0.0, "sensor": "p1",
                                                        "offset": 1e5, "drift": 0.0}}
        for _ in range(3):
            panel.sendto(json.dumps(fault).encode(), plant_addr)
        receive_until(lambda: all(i in answers for i in (*bad, 5)))
        k_fault = answers[5][0]["k"]
        panel.sendto(json.dumps(fault).encode(), plant_addr)      # a late copy: the same answer again
        receive_until(lambda: len(answers[5]) >= 2 and max(rows) > k_fault + 100)
        panel.sendto(json.dumps({"id": 6, "op": "stop"}).encode(), plant_addr)
        receive_until(lambda: 6 in answers)
        assert plant_p.wait(60) == 0 and ctl.wait(60) == 0, plant_p.stderr() + ctl.stderr()
    finally:
        for ch in (ctl, plant_p):
            if ch is not None and ch.poll() is None:
                ch.stop()
        panel.close()
    assert "mass" in answers[1][0]["error"] and "[0.1, 100000] kg" in answers[1][0]["error"]
    assert "sensor" in answers[2][0]["error"] and "warp" in answers[3][0]["error"]
    assert "slot" in answers[4][0]["error"] and "note" in answers[7][0]["error"]
    assert "probability" in answers[8][0]["error"]
    assert all(a == answers[5][0] for a in answers[5]) and answers[5][0]["slot"] == 0
    events = read_events(out / "events.jsonl", "plant")
    assert [(k, e.op) for k, evs in events.items() for e in evs] == [(k_fault, "fault_on")]     # applied once
    log = read_csv_columns(out / "plant_log.csv")
    ks = np.array(sorted(k for k in rows if k < len(log["k"])))
    assert len(ks) > 300
    tel = np.array([rows[k] for k in ks])
    for c in ("t", "xp", "vp", "xs", "p1", "p2", "ff", "u", "faults"):
        assert np.array_equal(tel[:, PLANT_COLUMNS.index(c)], log[c][ks]), c
    assert np.array_equal(tel[:, PLANT_COLUMNS.index("x_meas")], log["encoder"][ks] * 1e-6)
    assert np.all((log["faults"][ks] == 1) == (ks > k_fault))          # the fault from the step it was applied at
    from hydrohil.core import shape
    timing = json.loads((out / "timing.json").read_text())
    assert list(timing) == list(shape.timing_keys("lockstep", panel=True)) and timing["plant"] == plant
    assert timing["telemetry_batches_sent"] >= len(rows) // 20 and timing["stopped_early"] is True


# -- a circuit on the panel (a scenario naming its circuit) ----------------------------------------------------
MOTOR = EXAMPLES / "circuits" / "motor_speed" / "scenario.toml"


def test_circuit_steering_is_checked_against_the_circuit_and_a_set_value_derives_as_the_file_does():
    """The panel's changes to a circuit are refused with the input or parameter named (the loop's command, a
    value out of range with its unit, a misspelt key, a delay); a parameter changed while running gives the
    parameter vector the circuit built with that value (--set) has, derived values included (a cylinder's
    areas from its bore), and a held input replaces its drive."""
    from hydrohil.circuits.rig import CircuitRig
    from hydrohil.circuits.scenario import load_circuit_scenario
    from hydrohil.errors import InputError
    from hydrohil.simulation.steering import apply_circuit_event, parse_event
    cs = load_circuit_scenario(EXAMPLES / "circuits" / "servo_supply" / "scenario.toml")
    bad = {"valve.command": ({"op": "input", "name": "valve.command", "value": 0.1}, "controller drives it"),
           "cyl.mass": ({"op": "set", "name": "cyl.mass", "value": -5.0}, "kg"),
           "cyl.mas": ({"op": "set", "name": "cyl.mas", "value": 5.0}, "not a parameter of cyl"),
           "valve.delay": ({"op": "set", "name": "valve.delay", "value": 1e-3}, "sized when the run starts"),
           "pump.nope": ({"op": "input", "name": "pump.nope", "value": 1.0}, "not an input")}
    for key, (body, what) in bad.items():
        with pytest.raises(InputError, match=what) as exc:
            parse_event(body, "plant", circuit=cs)
        assert key in str(exc.value)
    with pytest.raises(InputError, match="value"):
        parse_event({"op": "reference", "value": float("nan")}, "controller", circuit=cs)
    rig = CircuitRig(cs)
    sets = {"cyl.area_a": 2.1e-3, "pump.volumetric_efficiency": 0.9, "fluid.density": 900.0, "cyl.mass": 80.0}
    for key, value in sets.items():
        apply_circuit_event(rig, parse_event({"op": "set", "name": key, "value": value}, "plant", circuit=cs), 0)
    built = load_circuit_scenario(cs.source, sets=sets).layout.values()
    assert np.array_equal(rig.P, built, equal_nan=True) and not np.array_equal(rig.P, cs.layout.values(), equal_nan=True)
    with pytest.raises(ValueError, match="cyl.bore: cyl: give bore and rod, or area_a and area_b"):   # (given by areas)
        apply_circuit_event(rig, parse_event({"op": "set", "name": "cyl.bore", "value": 0.05}, "plant", circuit=cs), 0)
    assert np.array_equal(rig.P, built, equal_nan=True)
    with pytest.raises(InputError, match="not a fluid parameter"):
        parse_event({"op": "set", "name": "fluid.densty", "value": 900.0}, "plant", circuit=cs)
    motor = load_circuit_scenario(MOTOR)
    rig = CircuitRig(motor)
    apply_circuit_event(rig, parse_event({"op": "input", "name": "motor.load_torque", "value": 7.5}, "plant",
                                         circuit=motor), 0)
    j = motor.layout.inputs.index("motor.load_torque")
    assert rig.step(0, None)[j] == 7.5
    apply_circuit_event(rig, parse_event({"op": "input", "name": "motor.load_torque", "value": None}, "plant",
                                         circuit=motor), 1)
    assert rig.step(1, None)[j] == rig.drives[1, j]
    # the loop's gains changed from the panel keep its command's clamp (its range, not the config's ±1)
    from hydrohil.simulation.steering import SteerableController
    motor.loop.limits = (0.0, 0.5)
    motor.loop.start(motor.step)
    SteerableController(motor.loop.controller, None).apply(parse_event({"op": "gains", "kp": 0.01}, "controller",
                                                                       circuit=motor))
    c = motor.loop.controller.c
    assert (c.kp, c.u_min, c.u_max) == (0.01, 0.0, 0.5)


@pytest.mark.slow
@pytest.mark.parametrize("plant", ["python", "c"])
def test_circuit_panel_session_replays_its_steering_bit_for_bit(tmp_path, plant):
    """``hydrohil panel`` on a circuit scenario (lock-step), on either plant: its own plots and forms, every kind
    of change (an input held and released, the loop's gains and reference, a parameter and the fluid changed,
    a reset; the C plant takes the slots the panel derives for a parameter) applied at a step and logged;
    refusals name the input or key; the recording is a run folder whose replay of the session's applied inputs
    and events gives its states bit for bit (and without the events does not)."""
    from hydrohil.circuits.scenario import load_circuit_scenario
    from hydrohil.hil.circuit import replay_applied_inputs, replay_circuit_session
    from hydrohil.hil.session import read_commands
    p = PanelProcess(tmp_path / "panel", MOTOR, "--lockstep", "--plant", plant)
    try:
        p.wait_steps(200)
        st = p.api("api/state")
        view = st["view"]
        assert view["kind"] == "circuit" and view["reference"]["shown"][1] == "rpm"
        assert [pl["id"] for pl in view["plots"]][:2] == ["c-loop", "c-error"] and st["fault_schema"] == []
        assert {i["name"]: i["controller"] for i in view["inputs"]} == {"valve.command": True,
                                                                        "motor.load_torque": False}
        sets = [{"op": "set", "name": "motor.inertia", "value": 0.02},
                {"op": "set", "name": "fluid.bulk_modulus", "value": 1.2e9}]
        steer = [{"op": "input", "name": "motor.load_torque", "value": 5.0},
                 {"op": "gains", "kp": 0.004},
                 sets[0],
                 {"op": "reference", "value": 40.0},
                 sets[1],
                 {"op": "input", "name": "motor.load_torque", "value": None},
                 {"op": "reset"}]
        rec, answers = _record(p, steer)
        assert [a["k"] for a in answers] == sorted(a["k"] for a in answers)
        refused = [({"op": "input", "name": "valve.command", "value": 0.1}, "valve.command"),
                   ({"op": "input", "name": "motor.load_torque", "value": 1e9}, "N.m"),
                   ({"op": "fault_on", "fault": {"type": "hose_burst"}}, "input")]
        refused += [({"op": "set", "name": "motor.inertia", "value": -1}, "kg.m2")]
        for body, what in refused:
            with pytest.raises(urllib.error.HTTPError) as exc:
                p.api("api/steer", body)
            assert exc.value.code == 400 and what in exc.value.read().decode()
        state = p.api("api/state")
        assert state["values"] == {"motor.inertia": 0.02, "fluid.bulk_modulus": 1.2e9}
        assert state["held"] == {}
        ended = p.api("api/run/stop", {})
        assert ended["exit_codes"] == {"plant": 0, "controller": 0} and ended["verdict"]["valid"]
    finally:
        p.close()
    session = p.session
    cs = load_circuit_scenario(session / "scenario.toml")
    assert cs.repeat                         # (a session runs until stopped: its drives and reference repeat)
    folder = session / "recordings" / rec["name"]
    for f in ("plant_log.csv", "timing.json", "events.jsonl", "controller_events.jsonl", "scenario.toml",
              "comparison.json", "report.png"):
        assert (folder / f).is_file(), f
    cmp = json.loads((folder / "comparison.json").read_text())
    assert cmp["identical"] and set(cmp["replay_max_abs_difference"]) == set(cs.layout.states)
    sets_logged = [e for e in map(json.loads, (session / "events.jsonl").read_text().splitlines()) if e["op"] == "set"]
    assert sets_logged[0]["slots"] == {str(cs.layout.slot["motor.inertia"]): 0.02}       # (no derived value)
    assert sets_logged[1]["slots"] == {str(cs.layout.slot["fluid.bulk_modulus"]): 1.2e9}   # (nothing derives
                                                                                          # from it)
    log = read_csv_columns(folder / "plant_log.csv")
    ks = log["k"].astype(int)
    assert np.array_equal(ks, np.arange(rec["k0"] + 1, rec["k1"] + 1))
    rep = replay_circuit_session(cs, session, steps=rec["k1"])
    for i, s in enumerate(cs.layout.states):
        assert np.array_equal(rep[ks, i], log[s]), s
    held = log["motor.load_torque.applied"]
    k_on, k_off = answers[0]["k"], answers[-2]["k"]
    assert np.all(held[(ks > k_on) & (ks <= k_off)] == 5.0) and not np.any(held[ks > k_off] == 5.0)
    assert len(read_events(session / "controller_events.jsonl", "controller", circuit=cs)) == 2
    # without the plant's events the same inputs give another run: the check can fail
    u = read_commands(session)
    plain = replay_applied_inputs(cs, u[:len(u) // 2 * 2].reshape(-1, 2)[:rec["k1"]])
    assert not np.array_equal(plain[ks, cs.layout.states.index("motor.w")], log["motor.w"])


@pytest.mark.slow
@pytest.mark.parametrize("plant", ["python", "c"])
def test_circuit_hil_panel_run_replays_its_steering(tmp_path, plant):
    """hydrohil hil --panel --lockstep on a circuit scenario, on either plant: a change made from the panel while
    it runs is in the run's event log, the report says the run was steered, and the replay of its applied inputs
    and events gives its states bit for bit."""
    scen = tmp_path / "long.toml"
    text = MOTOR.read_text().replace('circuit = "circuit.toml"', f'circuit = "{MOTOR.parent / "circuit.toml"}"')
    scen.write_text(text.replace("duration = 4.5", "duration = 30.0"))
    out = tmp_path / "run"
    ch, post = _hil_panel(scen, out, "--plant", plant)
    a = post({"op": "input", "name": "motor.load_torque", "value": 4.0})
    b = post({"op": "reference", "value": 50.0})
    assert ch.wait(600) == 0, ch.stderr()
    cmp = json.loads((out / "comparison.json").read_text())
    assert cmp["steered_events"] == {"plant": 1, "controller": 1} and "steered" in cmp["text"]
    assert cmp["replay_max_abs_difference"] == 0.0
    log = read_csv_columns(out / "plant_log.csv")
    assert np.all(log["motor.load_torque.applied"][log["k"] > a["k"]] == 4.0)
    assert np.all(log["motor.load_torque.applied"][(log["k"] <= a["k"]) & (log["t"] < 3.0)] == 0.0)
    assert b["k"] > 0
