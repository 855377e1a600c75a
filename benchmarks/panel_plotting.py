"""How to draw a 2 kHz stream in the browser: measured, not assumed (README, "Live panel").

In headless Chromium (Debian's chromium + chromedriver, as the tests), eight traces of a 2 kHz signal (a
sine with noise and a one-sample spike per second) in a 10 s and a 60 s window are drawn repeatedly by:

* ``canvas, min/max``: a 2D canvas drawing the min/max envelope of ~1 000 blocks per trace (what the panel
  does: the server decimates, the page draws);
* ``canvas, raw``: the same canvas drawing every sample;
* ``Plotly.js, min/max`` and ``Plotly.js, raw``: ``Plotly.react`` with the envelope / every sample (the
  plotly.min.js the ``plotly`` PyPI package ships: ``pip install plotly``).

Printed: the median time per frame (ms), the frames/s it allows, the bytes a frame carries (float32), and
whether the spike is visible. Usage: ``python benchmarks/panel_plotting.py [--seconds 3]``.
"""

from __future__ import annotations

import argparse
import json
import shutil
import tempfile
import threading
from functools import partial
from http.server import SimpleHTTPRequestHandler, ThreadingHTTPServer
from pathlib import Path

PAGE = r"""<!doctype html><html><body>
<div id="plot" style="width:1200px;height:800px"></div><canvas id="c" width="1200" height="800"></canvas>
<script src="plotly.min.js"></script>
<script>
"use strict";
function data(n, ntr) {
  const tr = [];
  for (let j = 0; j < ntr; j++) {
    const y = new Float32Array(n);
    for (let i = 0; i < n; i++) y[i] = Math.sin(2 * Math.PI * i / 4000 + j) + 0.05 * Math.random() + (i % 2000 === 777 ? 3 : 0);
    tr.push(y);
  }
  return tr;
}
function envelope(y, blocks) {
  const b = Math.ceil(y.length / blocks), lo = new Float32Array(blocks), hi = new Float32Array(blocks);
  for (let k = 0; k < blocks; k++) { let a = Infinity, c = -Infinity;
    for (let i = k * b; i < Math.min((k + 1) * b, y.length); i++) { if (y[i] < a) a = y[i]; if (y[i] > c) c = y[i]; }
    lo[k] = a; hi[k] = c; }
  return [lo, hi];
}
function canvasDraw(g, series, env) {
  g.clearRect(0, 0, 1200, 800);
  const H = 800 / series.length;
  series.forEach((s, j) => {
    g.beginPath();
    if (env) { const [lo, hi] = s, n = lo.length;
      for (let i = 0; i < n; i++) { const x = i * 1200 / n; if (i === 0) g.moveTo(x, j * H + H / 2 - hi[i] * H / 8); else g.lineTo(x, j * H + H / 2 - hi[i] * H / 8); g.lineTo(x, j * H + H / 2 - lo[i] * H / 8); } }
    else { const n = s.length; for (let i = 0; i < n; i++) { const x = i * 1200 / n, y = j * H + H / 2 - s[i] * H / 8; if (i === 0) g.moveTo(x, y); else g.lineTo(x, y); } }
    g.stroke();
  });
}
function plotlyTraces(series, env) {
  return series.map((s, j) => {
    if (env) { const [lo, hi] = s, n = lo.length, x = new Float32Array(2 * n), y = new Float32Array(2 * n);
      for (let i = 0; i < n; i++) { x[2 * i] = x[2 * i + 1] = i; y[2 * i] = hi[i] + 3 * j; y[2 * i + 1] = lo[i] + 3 * j; }
      return { x, y, mode: "lines", line: { width: 1 } }; }
    const y = new Float32Array(s.length); for (let i = 0; i < s.length; i++) y[i] = s[i] + 3 * j;
    return { y, mode: "lines", line: { width: 1 } };
  });
}
window.bench = async function (method, windowS, seconds) {
  const n = windowS * 2000, raw = data(n, 8), env = raw.map((y) => envelope(y, 1000));
  const series = method.endsWith("envelope") ? env : raw, isEnv = method.endsWith("envelope");
  const g = document.getElementById("c").getContext("2d"), times = [], draws = [];
  const t_end = performance.now() + seconds * 1000;
  if (method.startsWith("plotly")) await Plotly.newPlot("plot", plotlyTraces(series, isEnv), { showlegend: false }, { staticPlot: true });
  while (performance.now() < t_end && times.length < 500) {
    const t0 = performance.now();
    if (method.startsWith("canvas")) canvasDraw(g, series, isEnv);
    else await Plotly.react("plot", plotlyTraces(series, isEnv), { showlegend: false, datarevision: times.length }, { staticPlot: true });
    draws.push(performance.now() - t0);
    await new Promise((r) => requestAnimationFrame(r));
    times.push(performance.now() - t0);
  }
  times.sort((a, b) => a - b); draws.sort((a, b) => a - b);
  return { median_ms: times[times.length >> 1], draw_ms: draws[draws.length >> 1], frames: times.length,
           bytes_per_frame: isEnv ? 8 * 2 * 1000 * 4 : 8 * n * 4 };
};
</script></body></html>"""


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seconds", type=float, default=3.0, help="drawing time per case [s]")
    args = ap.parse_args(argv)
    try:
        import plotly
    except ImportError:
        raise SystemExit("pip install plotly (its plotly.min.js is one of the measured approaches)")
    from selenium import webdriver
    from selenium.webdriver.chrome.service import Service
    root = Path(tempfile.mkdtemp(prefix="hh-plot-bench-"))
    (root / "index.html").write_text(PAGE)
    shutil.copy(Path(plotly.__file__).parent / "package_data" / "plotly.min.js", root / "plotly.min.js")
    httpd = ThreadingHTTPServer(("127.0.0.1", 0), partial(SimpleHTTPRequestHandler, directory=str(root)))
    threading.Thread(target=httpd.serve_forever, daemon=True).start()
    opts = webdriver.ChromeOptions()
    opts.binary_location = shutil.which("chromium")
    for a in ("--headless=new", "--no-sandbox", "--disable-gpu", "--disable-dev-shm-usage", "--no-first-run",
              "--disable-background-networking", "--window-size=1300,1800", f"--user-data-dir={root / 'profile'}"):
        opts.add_argument(a)
    drv = webdriver.Chrome(service=Service(shutil.which("chromedriver")), options=opts)
    drv.set_script_timeout(300)
    try:
        drv.get(f"http://127.0.0.1:{httpd.server_address[1]}/index.html")
        rows = []
        for w in (10, 60):
            for m in ("canvas-envelope", "canvas-raw", "plotly-envelope", "plotly-raw"):
                r = drv.execute_async_script("const cb = arguments[arguments.length - 1];"
                                             f"bench('{m}', {w}, {args.seconds}).then(cb);")
                rows.append({"method": m, "window_s": w, **r})
                print(json.dumps(rows[-1]), flush=True)
    finally:
        drv.quit()
        httpd.shutdown()
        shutil.rmtree(root, ignore_errors=True)
    print("\n| approach | window | points per trace | script ms / frame | ms to the next painted frame | frames/s |"
          " bytes / frame |")
    print("|---|---|---|---|---|---|---|")
    for r in rows:
        pts = 1000 if r["method"].endswith("envelope") else r["window_s"] * 2000
        print(f"| {r['method']} | {r['window_s']} s | {pts:,} | {r['draw_ms']:.1f} | {r['median_ms']:.1f} | "
              f"{1000 / r['median_ms']:.0f} | {r['bytes_per_frame'] / 1e3:,.0f} kB |")


if __name__ == "__main__":
    main()
