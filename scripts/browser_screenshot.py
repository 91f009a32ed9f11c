"""Screenshots of a page in headless Chromium (Selenium with the system's Chromium and ChromeDriver), for the browser
viewer (``--viewer viser``): its committed screenshot and its test (tests/apps/test_browser_viewer.py).

    python play.py --checkpoint results/policies/cpg_rl_complex.pt --num_envs 3 --steps 6000 --viewer viser &
    python scripts/browser_screenshot.py http://127.0.0.1:8080 studies/viewer/viser_play.png --wait 40
"""

from __future__ import annotations

import argparse
import io
import shutil
import time


def browser(width: int = 960, height: int = 600):
    """Headless Chromium through Selenium, WebGL in software (SwiftShader) where there is no GPU."""
    from selenium import webdriver
    from selenium.webdriver.chrome.service import Service

    binary = shutil.which("chromium") or shutil.which("chromium-browser") or shutil.which("google-chrome")
    driver = shutil.which("chromedriver")
    if not binary or not driver:
        raise SystemExit("needs Chromium and ChromeDriver (Debian: apt-get install chromium chromium-driver)")
    opts = webdriver.ChromeOptions()
    opts.binary_location = binary
    for arg in ("--headless=new", "--no-sandbox", "--disable-dev-shm-usage", f"--window-size={width},{height}",
                "--use-angle=swiftshader", "--enable-unsafe-swiftshader", "--ignore-gpu-blocklist"):
        opts.add_argument(arg)
    chrome = webdriver.Chrome(service=Service(driver), options=opts)
    chrome.set_page_load_timeout(300)  # a loaded 2-core machine renders WebGL in software slowly
    return chrome


def screenshot(driver, tries: int = 10):
    """The page as an (H, W, 3) uint8 array; a renderer that does not answer in time (a busy machine) is asked again."""
    import numpy as np
    from PIL import Image
    from selenium.common.exceptions import TimeoutException

    for k in range(tries):
        try:
            png = driver.get_screenshot_as_png()
            break
        except TimeoutException:
            if k == tries - 1:
                raise
            time.sleep(10)
    return np.asarray(Image.open(io.BytesIO(png)).convert("RGB"))


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("url")
    p.add_argument("out", help="PNG file")
    p.add_argument("--wait", type=float, default=30.0, help="seconds after loading the page (default 30)")
    p.add_argument("--size", type=int, nargs=2, default=(960, 600), metavar=("W", "H"))
    args = p.parse_args()
    from PIL import Image

    d = browser(*args.size)
    try:
        d.get(args.url)
        time.sleep(args.wait)
        Image.fromarray(screenshot(d)).save(args.out)
    finally:
        d.quit()
    print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
