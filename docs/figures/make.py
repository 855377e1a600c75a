"""Redraw the README's figures: python docs/figures/make.py (from the repository root, package installed)."""

from pathlib import Path
import shutil
import sys
import tempfile

from hydrohil.compare import compare

ROOT = Path(__file__).resolve().parents[2]
EX = ROOT / "examples"
HERE = Path(__file__).resolve().parent

FIGURES = {
    "controllers_fig11.png": ([EX / "fig11_p_control.toml", EX / "controllers/fig11_pi.toml",
                               EX / "controllers/fig11_p_ff.toml"], ["P", "PI", "P+FF"],
                              "Fig 11: P, PI and P + velocity feed-forward"),
    "controllers_fig12.png": ([EX / "fig12_steps_ramps.toml", EX / "controllers/fig12_pressure_feedback.toml"],
                              ["P", "P + pressure feedback"], "Fig 12: P and P + dynamic load-pressure feedback"),
}

def freqresp_figures():
    from hydrohil.freqresp import freqresp
    from hydrohil.simulation.scenario import load_scenario
    sc = load_scenario(EX / "fig11_p_control.toml")
    for name, kw in (("freqresp_fig11.png", {}), ("freqresp_fig11_large.png", dict(amplitude=0.02, u_amplitude=0.3,
                                                                                   points=10))):
        with tempfile.TemporaryDirectory() as tmp:
            freqresp(sc, Path(tmp), **kw)
            shutil.copy(Path(tmp) / "bode.png", HERE / name)
        print("wrote", HERE / name)


def panel_figures():
    """Screenshots of the live panel in headless Chromium (Debian's chromium + chromedriver): the rig running
    Fig 11 after a supply drop to 40 bar and a hose burst on line 2; and a recording's report.png."""
    import time
    sys.path.insert(0, str(ROOT / "tests"))
    from conftest import PanelProcess
    from test_panel_browser import browser_driver
    with tempfile.TemporaryDirectory() as tmp:
        p = PanelProcess(Path(tmp) / "panel")
        drv = browser_driver(Path(tmp))
        try:
            drv.get(p.url)
            p.wait_steps(int(7 / 5e-4))
            p.api("api/record/start", {})
            p.wait_steps(int(8 / 5e-4))
            p.api("api/steer", {"op": "set", "name": "supply_pressure", "value": 40e5})
            p.wait_steps(int(10 / 5e-4))
            p.api("api/steer", {"op": "fault_on", "fault": {"type": "hose_burst", "line": 2, "section": 0.3}})
            p.wait_steps(int(11.5 / 5e-4))
            p.api("api/steer", {"op": "fault_off", "slot": 0})
            p.wait_steps(int(13 / 5e-4))
            time.sleep(0.5)              # a few frames drawn after the last change
            drv.save_screenshot(str(HERE / "panel.png"))
            rec = p.api("api/record/stop", {})
            p.api("api/run/stop", {})
            shutil.copy(Path(rec["dir"]) / "report.png", HERE / "panel_recording.png")
        finally:
            drv.quit()
            p.close()
    print("wrote", HERE / "panel.png", HERE / "panel_recording.png")


def circuit_panel_figure():
    """The live panel on a circuit (examples/circuits/motor_speed): its loop's speed, a 6 N.m load torque held
    from the page and given back to its drive, the motor's inertia tripled."""
    import time
    sys.path.insert(0, str(ROOT / "tests"))
    from conftest import PanelProcess
    from test_panel_browser import browser_driver
    with tempfile.TemporaryDirectory() as tmp:
        p = PanelProcess(Path(tmp) / "panel", ROOT / "examples" / "circuits" / "motor_speed" / "scenario.toml")
        drv = browser_driver(Path(tmp))
        try:
            drv.get(p.url)
            p.wait_steps(int(2.5 / 5e-4))
            p.api("api/steer", {"op": "input", "name": "motor.load_torque", "value": 6.0})
            p.wait_steps(int(3.5 / 5e-4))
            p.api("api/steer", {"op": "set", "name": "motor.inertia", "value": 0.03})
            p.wait_steps(int(5.5 / 5e-4))
            p.api("api/steer", {"op": "input", "name": "motor.load_torque", "value": None})
            p.wait_steps(int(8 / 5e-4))
            time.sleep(0.5)              # a few frames drawn after the last change
            drv.save_screenshot(str(HERE / "panel_circuit.png"))
            p.api("api/run/stop", {})
        finally:
            drv.quit()
            p.close()
    print("wrote", HERE / "panel_circuit.png")


def circuit_figures():
    """The example circuits of examples/circuits/ (hydrohil circuit run)."""
    from hydrohil.circuits.circuit import CIRCUITS_DIR as CIRCUITS, load_circuit
    from hydrohil.circuits.run import simulate_circuit
    from hydrohil.circuits.show import default_duration, plot_run
    for name, file, title in (
            ("pump_relief_accumulator", "circuit_supply.png",
             "pump, relief valve and accumulator: the load opens at 2 s, closes at 4 s (RK3 at 0.5 ms)"),
            ("two_cylinders", "circuit_two_cylinders.png",
             "two valve-controlled cylinders on one pump (RK3 at 0.5 ms)")):
        c = load_circuit(name)
        plot_run(simulate_circuit(c, default_duration(c)), HERE / file, title)
        print("wrote", HERE / file)
    from hydrohil.circuits.scenario import load_circuit_scenario, run_circuit_scenario
    for name, file, title in (
            ("motor_speed", "circuit_motor_speed.png",
             "PI speed control of a valve-controlled motor: 1000 rpm, 600 rpm, a 10 N·m load at 3 s"),
            ("counterbalance_hose_burst", "circuit_counterbalance.png",
             "1000 kg lifted through a counterbalance valve; the A hose bursts at 1.5 s: the load stays"),
            ("servo_supply", "circuit_servo_supply.png",
             "the paper's servo valve and cylinder under P control, fed by a pump and an accumulator"),
            ("lift_platform", "circuit_lift_platform.png",
             "a deck on two coupled cylinders under P control: raised, a 4 kN payload ramped on, lowered")):
        res, _ = run_circuit_scenario(load_circuit_scenario(CIRCUITS / name / "scenario.toml"))
        plot_run(res, HERE / file, title)
        print("wrote", HERE / file)
    circuit_diagrams()


def circuit_diagrams():
    """Every example circuit as ``circuit draw --scenario`` draws it (its ISO 1219 symbols, its faults in red)."""
    from hydrohil.circuits.circuit import CIRCUITS_DIR as CIRCUITS
    from hydrohil.circuits.draw import draw_circuit
    from hydrohil.circuits.scenario import load_circuit_scenario
    for name in sorted(p.name for p in CIRCUITS.iterdir() if (p / "scenario.toml").exists()):
        scenario = load_circuit_scenario(CIRCUITS / name / "scenario.toml")       # (as it runs: its faults marked)
        draw_circuit(scenario.circuit, HERE / f"circuit_{name}_diagram.png", faults=scenario.faults,
                     loop=scenario.loop)
        print("wrote", HERE / f"circuit_{name}_diagram.png")


if __name__ == "__main__":
    if sys.argv[1:] in (["panel"], ["circuit"], ["circuit_panel"], ["diagrams"]):
        {"panel": panel_figures, "circuit": circuit_figures, "circuit_panel": circuit_panel_figure,
         "diagrams": circuit_diagrams}[sys.argv[1]]()
        raise SystemExit
    circuit_figures()
    panel_figures()
    circuit_panel_figure()
    freqresp_figures()
    for name, (runs, labels, title) in FIGURES.items():
        with tempfile.TemporaryDirectory() as tmp:
            compare(runs, Path(tmp), labels=labels, title=title)
            shutil.copy(Path(tmp) / "compare.png", HERE / name)
        print("wrote", HERE / name)
