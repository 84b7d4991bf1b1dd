#!/usr/bin/env python3
"""The run report as a person sees it: `weldtwin run` on the default cell writes report.html (twice: the pictures
must be the same bytes); headless Chromium opens a copy of it with a probe script added; every picture must
decode and not be blank (pixel spread), and neither the page nor its console may report an error. The
benchmark report (`weldtwin bench` + `bench-report` on three trials) is opened the same way.
Usage: report_browser_test.py WELDTWIN_BINARY"""
import json
import os
import re
import shutil
import subprocess
import sys
import tempfile

PROBE_HEAD = """<script>
window.__errors = [];
window.addEventListener('error', e => window.__errors.push(String(e.message || e.type)), true);
const __consoleError = console.error;
console.error = (...a) => { window.__errors.push(a.join(' ')); __consoleError(...a); };
</script>"""

PROBE_TAIL = """<script>
window.addEventListener('load', async () => {
  const out = {images: [], errors: window.__errors};
  for (const img of document.images) {
    const r = {alt: img.alt, width: img.naturalWidth, height: img.naturalHeight, spread: 0, decoded: false};
    r.decoded = img.complete && img.naturalWidth > 0;  // data: pictures have all loaded by 'load'
    if (r.decoded && r.width > 0) {
      const c = document.createElement('canvas');
      c.width = r.width; c.height = r.height;
      const g = c.getContext('2d');
      g.drawImage(img, 0, 0);
      const px = g.getImageData(0, 0, r.width, r.height).data;
      let s = 0, s2 = 0, n = 0;
      for (let i = 0; i < px.length; i += 4 * 7) { const v = px[i] + px[i + 1] + px[i + 2]; s += v; s2 += v * v; n++; }
      r.spread = Math.sqrt(Math.max(0, s2 / n - (s / n) * (s / n)));
    }
    out.images.push(r);
  }
  const pre = document.createElement('pre');
  pre.id = 'probe';
  pre.textContent = JSON.stringify(out);
  document.body.appendChild(pre);
});
</script>"""


def open_in_browser(chromium, html_path, tmp, min_images):
    """Opens the page with the probe added; returns (failures, images, page text)."""
    html = open(html_path, encoding="utf-8").read()
    failures = []
    # Self-contained: nothing is fetched from elsewhere.
    external = re.findall(r'(?:src|href)="(?!data:)([^"#]+)"', html)
    if external:
        failures.append("%s refers to other files: %s" % (html_path, external[:5]))
    probe = html.replace("<head>", "<head>" + PROBE_HEAD, 1).replace("</body>", PROBE_TAIL + "</body>", 1)
    page = os.path.join(tmp, "probe.html")
    open(page, "w", encoding="utf-8").write(probe)
    browser = subprocess.run(
        [chromium, "--headless", "--no-sandbox", "--disable-gpu", "--disable-dev-shm-usage",
         "--user-data-dir=" + os.path.join(tmp, "profile"), "--enable-logging=stderr", "--v=0",
         "--virtual-time-budget=20000", "--dump-dom", "file://" + page],
        capture_output=True, text=True, timeout=180)
    m = re.search(r'<pre id="probe">(.*?)</pre>', browser.stdout, re.S)
    if not m:
        return ["the probe did not report; chromium said: " + browser.stderr[-2000:]], [], ""
    result = json.loads(m.group(1).replace("&quot;", '"').replace("&amp;", "&").replace("&lt;", "<").replace("&gt;", ">"))
    console_errors = [l for l in browser.stderr.splitlines() if "CONSOLE" in l and ("ERROR" in l or "Uncaught" in l)]
    if len(result["images"]) < min_images:
        failures.append("only %d pictures in %s (%d expected)" % (len(result["images"]), html_path, min_images))
    for img in result["images"]:
        if not img["decoded"] or img["width"] == 0:
            failures.append("picture '%s' does not decode" % img["alt"])
        elif img["spread"] < 5:
            failures.append("picture '%s' is blank (pixel spread %.1f)" % (img["alt"], img["spread"]))
    failures += ["page error: " + e for e in result["errors"]]
    failures += ["console: " + l for l in console_errors]
    for img in result["images"]:
        print("  %-36s %4dx%-4d spread %.0f" % (img["alt"], img["width"], img["height"], img["spread"]))
    text = re.sub(r"<[^>]+>", " ", browser.stdout)
    return failures, result["images"], text


def main():
    weldtwin = sys.argv[1]
    chromium = shutil.which("chromium") or shutil.which("chromium-browser")
    if not chromium:
        print("report_browser_test: chromium is not installed (scripts/setup installs it)")
        return 1
    with tempfile.TemporaryDirectory() as tmp:
        out = os.path.join(tmp, "run")
        run = subprocess.run([weldtwin, "run", "--out", out, "-q"], capture_output=True, text=True)
        if run.returncode not in (0, 3) or not os.path.exists(os.path.join(out, "report.html")):
            print("weldtwin run failed:", run.returncode, run.stdout, run.stderr)
            return 1
        # The same cell again: every picture must come out byte for byte the same.
        out2 = os.path.join(tmp, "run2")
        subprocess.run([weldtwin, "run", "--out", out2, "-q"], capture_output=True, text=True)
        pngs = sorted(f for f in os.listdir(out) if f.endswith(".png"))
        differ = [f for f in pngs if not os.path.exists(os.path.join(out2, f)) or
                  open(os.path.join(out, f), "rb").read() != open(os.path.join(out2, f), "rb").read()]
        if len(pngs) < 8 or differ:
            print("pictures not reproduced: %s (of %d)" % (differ, len(pngs)))
            return 1
        failures, images, _ = open_in_browser(chromium, os.path.join(out, "report.html"), tmp, 8)

        # The benchmark's report: a few trials, both methods; its three plots and its headline.
        results = os.path.join(tmp, "bench", "results.jsonl")
        bench = subprocess.run([weldtwin, "bench", "--trials", "3", "--seed", "2", "--no-replay", "-q",
                                "--out", results], capture_output=True, text=True)
        report = subprocess.run([weldtwin, "bench-report", results, "--out", os.path.join(tmp, "bench")],
                                capture_output=True, text=True)
        if bench.returncode != 0 or report.returncode != 0:
            failures.append("weldtwin bench / bench-report failed: %s %s" % (bench.stderr, report.stderr))
        else:
            bench_failures, bench_images, text = open_in_browser(
                chromium, os.path.join(tmp, "bench", "report.html"), tmp, 3)
            failures += bench_failures
            if "every seam point within 1 mm in" not in text or "3 random cells" not in text:
                failures.append("the benchmark page does not lead with its headline")
            images += bench_images
        if failures:
            print("\n".join(failures))
            return 1
        print("report_browser_test: %d pictures decode and show something; no errors" % len(images))
        return 0


if __name__ == "__main__":
    sys.exit(main())
