#!/usr/bin/env python3
"""The run report as a person sees it: `weldtwin run` on the default cell writes report.html (twice: the pictures
must be the same bytes); headless Chromium opens a copy of it with a probe script added; every picture must
decode and not be blank (pixel spread), and neither the page nor its console may report an error.
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
        html = open(os.path.join(out, "report.html"), encoding="utf-8").read()
        # Self-contained: nothing is fetched from elsewhere.
        external = re.findall(r'(?:src|href)="(?!data:)([^"#]+)"', html)
        if external:
            print("the report refers to other files:", external[:5])
            return 1
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
            print("the probe did not report; chromium said:", browser.stderr[-2000:])
            return 1
        result = json.loads(m.group(1).replace("&quot;", '"').replace("&amp;", "&").replace("&lt;", "<").replace("&gt;", ">"))
        console_errors = [l for l in browser.stderr.splitlines() if "CONSOLE" in l and ("ERROR" in l or "Uncaught" in l)]
        failures = []
        if len(result["images"]) < 8:
            failures.append("only %d pictures (renders and plots expected)" % len(result["images"]))
        for img in result["images"]:
            if not img["decoded"] or img["width"] == 0:
                failures.append("picture '%s' does not decode" % img["alt"])
            elif img["spread"] < 5:
                failures.append("picture '%s' is blank (pixel spread %.1f)" % (img["alt"], img["spread"]))
        failures += ["page error: " + e for e in result["errors"]]
        failures += ["console: " + l for l in console_errors]
        for img in result["images"]:
            print("  %-36s %4dx%-4d spread %.0f" % (img["alt"], img["width"], img["height"], img["spread"]))
        if failures:
            print("\n".join(failures))
            return 1
        print("report_browser_test: %d pictures decode and show something; no errors" % len(result["images"]))
        return 0


if __name__ == "__main__":
    sys.exit(main())
