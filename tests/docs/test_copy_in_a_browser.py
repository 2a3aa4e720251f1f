"""In a real browser, a console block's copy text is its commands only.

The site is built, and the tutorial page is loaded in headless Chromium with a probe that does
what Material's copy button does (mark the block ``data-md-copying``, take its ``innerText``);
the texts must be the page's ``$`` commands exactly. Skipped where Chromium is not installed.
"""

from __future__ import annotations

import html
import json
import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
PAGE = "tutorials/first-simulator-run"
PROBE = """<script>
window.addEventListener('load', () => {
  const out = [];
  for (const el of [...document.querySelectorAll('div.highlight pre > code')]
                   .filter(e => e.querySelector('.gp'))) {
    el.setAttribute('data-md-copying', '');
    out.push(el.innerText.trimEnd());
    el.removeAttribute('data-md-copying');
  }
  const pre = document.createElement('pre');
  pre.id = 'copied';
  pre.textContent = JSON.stringify(out);
  document.body.appendChild(pre);
});
</script></body>"""
#: Seconds the browser may take to load the page (it loads no network resource).
BROWSER_TIMEOUT_S = 60


@pytest.mark.slow  # a whole mkdocs build, then a browser
def test_the_copy_text_of_each_console_block_is_its_commands(tmp_path: Path) -> None:
    browser = shutil.which("chromium") or shutil.which("chromium-browser")
    if browser is None:
        pytest.skip("Chromium is not installed")
    site = tmp_path / "site"
    subprocess.run([sys.executable, "-m", "mkdocs", "build", "-q", "--site-dir", str(site)],
                   cwd=ROOT, check=True, capture_output=True)
    page = site / PAGE / "index.html"
    probe = page.with_name("probe.html")
    probe.write_text(page.read_text(encoding="utf-8").replace("</body>", PROBE),
                     encoding="utf-8")
    dom = subprocess.run([browser, "--headless", "--no-sandbox", "--disable-gpu",
                          "--virtual-time-budget=3000", "--dump-dom", probe.as_uri()],
                         capture_output=True, text=True, timeout=BROWSER_TIMEOUT_S).stdout
    found = re.search(r'<pre id="copied">(.*?)</pre>', dom, re.S)
    assert found is not None, dom[-2000:]
    copied = json.loads(html.unescape(found[1]))
    source = (ROOT / "docs" / f"{PAGE}.md").read_text(encoding="utf-8")
    commands = [ln[2:] for ln in source.splitlines() if ln.startswith("$ ")]
    assert copied == commands
