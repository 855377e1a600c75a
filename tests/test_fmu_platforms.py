"""FMUs for every importer (issue #28 §1-2): each FMU carries its C sources, declared (FMI 2's <SourceFiles>, FMI 3's
sources/buildDescription.xml), which build with no flag of their own (FMPy's build_platform_binary, plain gcc and
clang) into a binary that gives the same numbers; binaries for x86-64 Linux, aarch64 Linux and 64-bit Windows from
the same sources (Debian's cross compilers, which .ci/run installs), each exporting the FMI functions and nothing
else, the Linux ones needing glibc as old as the code allows; the aarch64 binary runs a Fig 11 co-simulation under
qemu-user and the Windows one under wine, from a small C importer (tests/c/fmu_cosim.c)."""

import os
import shutil
import struct
import subprocess
import zipfile
from pathlib import Path

import numpy as np
import pytest
from fmpy import read_model_description
from fmpy.validation import validate_fmu

from conftest import EXAMPLES
from hydrohil.export.fmu import MODEL_IDENTIFIER, TARGETS, export_fmu
from hydrohil.parameters import load_parameters
from hydrohil.simulation.run import run_scenario
from hydrohil.simulation.scenario import load_scenario

HERE = Path(__file__).resolve().parent
TOOLS = {"aarch64-linux-gnu-gcc": "gcc-aarch64-linux-gnu", "x86_64-w64-mingw32-gcc": "gcc-mingw-w64-x86-64",
         "qemu-aarch64": "qemu-user", "/usr/lib/wine/wine64": "wine64", "clang": "clang", "cmake": "cmake (FMPy's)"}
FIG11_SECONDS = 2.0


def need(tool: str) -> str:
    """The path of ``tool``, or the test fails saying .ci/run installs it (never skipped)."""
    path = tool if os.path.isabs(tool) and os.access(tool, os.X_OK) else shutil.which(tool)
    if path is None:
        pytest.fail(f"{tool} is not installed: .ci/run installs it (apt-get install {TOOLS[tool]})")
    return path


@pytest.fixture(scope="module")
def fmus(tmp_path_factory):
    """The paper's rig exported with every platform's binary, FMI 2 and FMI 3: {fmi: (path, unzipped folder)}."""
    for tool in ("aarch64-linux-gnu-gcc", "x86_64-w64-mingw32-gcc"):
        need(tool)
    tmp = tmp_path_factory.mktemp("platforms")
    out = {}
    for fmi in (2, 3):
        path = export_fmu(load_parameters("ferreira2004"), tmp / f"plant{fmi}.fmu", fmi=fmi)
        folder = tmp / f"u{fmi}"
        with zipfile.ZipFile(path) as z:
            z.extractall(folder)
        out[fmi] = path, folder
    return out


def _binary(folder: Path, fmi: int, target: str) -> Path:
    fmi2_dir, fmi3_dir, suffix = TARGETS[target][:3]
    return folder / "binaries" / (fmi2_dir if fmi == 2 else fmi3_dir) / f"{MODEL_IDENTIFIER}{suffix}"


def _fig11(tmp_path: Path):
    """(the Fig 11 scenario for FIG11_SECONDS, the file of its reference per step, simulate's xp per step)."""
    sc = load_scenario(EXAMPLES / "fig11_p_control.toml", duration=FIG11_SECONDS)
    ref = tmp_path / "reference.txt"
    ref.write_text("\n".join(repr(float(x)) for x in sc.scenario.references()[0]) + "\n")
    return sc, ref, run_scenario(sc).column("xp")


def _cosim(cmd: list, binary: Path, md, sc, ref: Path, env=None) -> np.ndarray:
    """xp per step of tests/c/fmu_cosim.c (built: ``cmd`` its command prefix, e.g. qemu's) on ``binary``."""
    vr = {v.name: v.valueReference for v in md.modelVariables}
    s = sc.scenario
    r = subprocess.run([*cmd, str(binary), md.guid, str(ref), repr(s.solver.step), repr(s.controller.kp),
                        repr(sc.params.sensors.encoder_resolution), str(vr["u"]), str(vr["xp"]), str(vr["encoder"]),
                        str(vr["initial.xp"]), repr(s.initial.xp)],
                       capture_output=True, text=True, timeout=600, env=env)
    assert r.returncode == 0, r.stderr[-2000:]
    return np.array([struct.unpack(">d", bytes.fromhex(line))[0] for line in r.stdout.split()])


def _harness(tmp_path: Path, cc: str, name: str, *flags) -> Path:
    exe = tmp_path / name
    fmpy_headers = Path(__import__("fmpy").__file__).parent / "c-code"
    r = subprocess.run([cc, "-std=c99", "-O2", "-Wall", "-Wextra", "-Werror", "-I", str(fmpy_headers),
                        str(HERE / "c" / "fmu_cosim.c"), "-o", str(exe), *flags], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    return exe


@pytest.mark.slow
@pytest.mark.parametrize("fmi", [2, 3])
def test_the_sources_are_declared_and_rebuild_the_same_binary(fmus, fmi, tmp_path):
    """The FMU names its C files (FMI 2: <SourceFiles> in its CoSimulation; FMI 3: sources/buildDescription.xml,
    C99, no definitions) and FMPy validates both files; FMPy's build_platform_binary, from the FMU alone (its
    binaries deleted), builds one that gives the exported binary's run of Fig 11, bit for bit."""
    import sys
    from fmpy import simulate_fmu
    from fmpy.build import build_platform_binary
    os.environ["PATH"] = f"{Path(sys.executable).parent}{os.pathsep}{os.environ['PATH']}"   # (FMPy's cmake)
    need("cmake")
    path, folder = fmus[fmi]
    assert validate_fmu(str(path)) == []
    md = read_model_description(str(path))
    declared = md.buildConfigurations[0].sourceFileSets[0].sourceFiles
    assert declared[:4] == ["hh_core.c", "paper_circuit.c", "paper_model.c", "plant_fmu.c"]
    assert declared[4:] == ["fmu_instance.c", f"fmi{fmi}Functions.c"]
    assert all((folder / "sources" / f).is_file() for f in declared)
    if fmi == 3:
        assert (folder / "sources" / "buildDescription.xml").is_file()
        assert md.buildConfigurations[0].sourceFileSets[0].language == "C99"
    rebuilt = tmp_path / "rebuilt"
    shutil.copytree(folder, rebuilt)
    shutil.rmtree(rebuilt / "binaries")
    (tmp_path / "build").mkdir()
    build_platform_binary(rebuilt, build_dir=tmp_path / "build")
    assert _binary(rebuilt, fmi, "x86_64-linux").is_file()
    kw = dict(stop_time=1.0, output_interval=5e-4, input=np.array([(0.0, 0.3), (0.4, -0.2)],
                                                                 dtype=[("time", float), ("u", float)]),
              output=["xp", "p1", "p2"])
    a, b = simulate_fmu(str(folder), **kw), simulate_fmu(str(rebuilt), **kw)
    for name in ("xp", "p1", "p2"):
        assert np.array_equal(a[name], b[name]), name
    assert np.ptp(a["xp"]) > 1e-3                        # (the command moved the piston)


@pytest.mark.slow
def test_every_binary_exports_the_fmi_functions_and_needs_an_old_glibc(fmus):
    """Each of the three binaries of each FMU exports the standard's functions (all of them: 44 of FMI 2, 75 of FMI 3) and no
    other symbol; the Linux ones need glibc 2.2.5 on x86-64 and 2.17 on aarch64 (each architecture's first), the
    Windows one only KERNEL32.dll and msvcrt.dll."""
    import re
    from hydrohil.export.fmu import _fmi_headers
    # every function the standard's header names (FMI 2: 44, both interfaces; FMI 3: 75), read from FMPy's copy
    functions = {v: len(set(re.findall(rf"#define (fmi{v}\w+)\s+fmi{v}FullName", _fmi_headers(v)[0].read_text())))
                 for v in (2, 3)}
    assert functions == {2: 44, 3: 75}
    for fmi, (_, folder) in fmus.items():
        for target in TARGETS:
            binary = _binary(folder, fmi, target)
            assert binary.is_file(), binary
            if target.endswith("windows"):
                text = subprocess.run([need("x86_64-w64-mingw32-gcc").replace("gcc", "objdump"), "-p", str(binary)],
                                      capture_output=True, text=True, check=True).stdout
                table = text[text.index("[Ordinal/Name Pointer] Table"):]
                names = re.findall(r"\]\s+(\w+)", table.split("\n\n")[0].split("\n", 1)[1])   # (its rows)
                dlls = sorted(set(re.findall(r"DLL Name: (\S+)", text)))
                assert dlls == ["KERNEL32.dll", "msvcrt.dll"], dlls
            else:
                nm = "nm" if target == "x86_64-linux" else "aarch64-linux-gnu-nm"
                names = [line.split()[-1] for line in subprocess.run(
                    [nm, "-D", "--defined-only", str(binary)], capture_output=True, text=True,
                    check=True).stdout.splitlines()]
                dump = subprocess.run([nm.replace("nm", "objdump"), "-T", str(binary)], capture_output=True,
                                      text=True, check=True).stdout
                versions = {tuple(int(x) for x in v.split(".")) for v in re.findall(r"GLIBC_([0-9.]+)", dump)}
                assert max(versions) == ((2, 2, 5) if target == "x86_64-linux" else (2, 17)), (target, versions)
            fmi_names = [n for n in names if n.startswith(f"fmi{fmi}")]
            assert len(fmi_names) == functions[fmi] and len(names) == len(fmi_names), (fmi, target, names)


@pytest.mark.slow
def test_the_aarch64_binary_runs_fig_11_under_qemu_as_x86_64_does_bit_for_bit(fmus, tmp_path):
    """A C importer (tests/c/fmu_cosim.c) runs Fig 11's P loop on the FMU's aarch64 binary under qemu-user and on
    its x86-64 one: the same positions at every step, bit for bit, and `hydrohil simulate`'s; the sources built
    with no flag at all by plain gcc and clang on this machine, and for aarch64, give them too."""
    _, folder = fmus[2]
    md = read_model_description(str(folder))
    sc, ref, offline = _fig11(tmp_path)
    native = _cosim([str(_harness(tmp_path, "cc", "cosim", "-ldl"))], _binary(folder, 2, "x86_64-linux"), md, sc, ref)
    assert np.array_equal(native, offline)
    qemu = [need("qemu-aarch64"), "-L", "/usr/aarch64-linux-gnu",
            str(_harness(tmp_path, need("aarch64-linux-gnu-gcc"), "cosim_a64", "-ldl"))]
    assert np.array_equal(_cosim(qemu, _binary(folder, 2, "aarch64-linux"), md, sc, ref), native)
    src = folder / "sources"
    units = [str(src / f) for f in md.buildConfigurations[0].sourceFileSets[0].sourceFiles]
    here = [str(tmp_path / "cosim")]
    for cc, name, importer in (("gcc", "plain_gcc.so", here), (need("clang"), "plain_clang.so", here),
                               (need("aarch64-linux-gnu-gcc"), "plain_a64.so", qemu)):
        so = tmp_path / name                   # (no -std, no -ffp-contract, no -O: the compiler's defaults)
        r = subprocess.run([cc, "-shared", "-fPIC", "-I", str(src), *units, "-lm", "-o", str(so)],
                           capture_output=True, text=True)
        assert r.returncode == 0, r.stderr
        assert np.array_equal(_cosim(importer, so, md, sc, ref), native), name
    assert np.ptp(native) > 0.05                         # (Fig 11's moves)


@pytest.mark.slow
def test_the_windows_binary_runs_fig_11_under_wine(fmus, tmp_path):
    """The same C importer built for Windows (mingw-w64) runs Fig 11 on the FMU's win64 binary under wine: the
    run of x86-64 Linux and `hydrohil simulate`'s, bit for bit (mingw-w64's exp gives glibc's numbers here: a whole
    6 s Fig 11 measured so too)."""
    wine = need("/usr/lib/wine/wine64")
    _, folder = fmus[2]
    md = read_model_description(str(folder))
    sc, ref, offline = _fig11(tmp_path)
    exe = _harness(tmp_path, need("x86_64-w64-mingw32-gcc"), "cosim.exe")
    env = {**os.environ, "WINEPREFIX": str(tmp_path / "wine"), "WINEDEBUG": "-all"}
    win = _cosim([wine, str(exe)], _binary(folder, 2, "x86_64-windows"), md, sc, ref, env=env)
    assert np.array_equal(win, offline), np.max(np.abs(win - offline))
