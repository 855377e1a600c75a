"""Redraw the README's figures: python docs/figures/make.py (from the repository root, package installed)."""

from pathlib import Path
import shutil
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


if __name__ == "__main__":
    freqresp_figures()
    for name, (runs, labels, title) in FIGURES.items():
        with tempfile.TemporaryDirectory() as tmp:
            compare(runs, Path(tmp), labels=labels, title=title)
            shutil.copy(Path(tmp) / "compare.png", HERE / name)
        print("wrote", HERE / name)
