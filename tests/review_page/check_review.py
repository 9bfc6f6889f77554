#!/usr/bin/env python3
"""The review page of `--report` in a real browser (Debian's chromium, headless).

A report of 300 clips (the demo's noisy clips, copied into 75 folders) must load with no
JavaScript error in under 2 s and list exactly the clips cleaned; opening a clip (#clip=N) must
draw both skeletons: the screenshot holds pixels of the before (orange) and after (blue) colours
in the 3-D view. Exits 77 (CTest: skipped) with a message when chromium or PIL is absent, or the
program was built without three.js."""
import argparse
import os
import re
import shutil
import subprocess
import sys
import tempfile
import time


def skip(message):
    print(f"SKIP: {message}")
    sys.exit(77)


def fail(message):
    print(f"FAIL: {message}")
    sys.exit(1)


def chromium_command():
    for name in ("chromium", "chromium-browser"):
        path = shutil.which(name)
        if path:
            return path
    skip("chromium is not installed (apt-get install chromium; scripts/setup.sh does)")


def browse(chromium, url, *extra, budget_ms=None):
    args = [chromium, "--headless", "--disable-gpu-sandbox", "--use-angle=swiftshader",
            "--enable-unsafe-swiftshader", "--window-size=1280,860", "--hide-scrollbars",
            "--enable-logging=stderr", "--v=0", "--no-first-run", "--disable-extensions",
            f"--user-data-dir={os.path.join(WORK, 'profile')}"]
    if os.geteuid() == 0:
        args.append("--no-sandbox")  # chromium refuses to run as root with its sandbox
    if budget_ms:
        args.append(f"--virtual-time-budget={budget_ms}")
    result = subprocess.run(args + list(extra) + [url], capture_output=True, text=True, timeout=120)
    errors = [line for line in result.stderr.splitlines()
              if "CONSOLE" in line and ("Uncaught" in line or "Error" in line)]
    if errors:
        fail(f"JavaScript errors on {url}:\n" + "\n".join(errors))
    return result.stdout


def status_of(dom):
    m = re.search(r'<span id="status"([^>]*)>([^<]*)<', dom)
    if not m:
        fail("the page has no #status element")
    attributes = dict(re.findall(r'data-([a-z]+)="([^"]*)"', m.group(1)))
    return attributes, m.group(2)


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--binary", required=True)
    parser.add_argument("--work", required=True)
    parser.add_argument("--clips", type=int, default=300)
    args = parser.parse_args()
    global WORK
    WORK = args.work
    chromium = chromium_command()
    try:
        from PIL import Image
    except ImportError:
        skip("python3-pil is not installed (apt-get install python3-pil; scripts/setup.sh does)")

    shutil.rmtree(WORK, ignore_errors=True)
    os.makedirs(WORK)
    demo = os.path.join(WORK, "demo")
    subprocess.run([args.binary, "demo", "-o", demo, "--json"], check=True,
                   stdout=subprocess.DEVNULL)
    noisy = sorted(os.path.relpath(os.path.join(d, f), os.path.join(demo, "noisy"))
                   for d, _, files in os.walk(os.path.join(demo, "noisy")) for f in files
                   if f.endswith(".bvh"))
    if not noisy:
        fail("the demo wrote no noisy clips")
    source = os.path.join(WORK, "source")
    expected = []
    for k in range(args.clips):
        rel = os.path.join(f"take{k // len(noisy):03d}", noisy[k % len(noisy)])
        os.makedirs(os.path.dirname(os.path.join(source, rel)), exist_ok=True)
        shutil.copyfile(os.path.join(demo, "noisy", noisy[k % len(noisy)]), os.path.join(source, rel))
        expected.append(rel)
    report = os.path.join(WORK, "review")
    started = time.monotonic()
    run = subprocess.run([args.binary, "clean", source, "-o", os.path.join(WORK, "out"),
                          "--report", report], capture_output=True, text=True)
    if run.returncode == 2 and "three.js" in run.stderr:
        skip("this mocap-clean was built without three.js: " + run.stderr.strip())
    if run.returncode != 0:
        fail(f"clean --report exited {run.returncode}: {run.stderr}")
    print(f"clean --report of {args.clips} clips: {time.monotonic() - started:.1f} s")
    size = sum(os.path.getsize(os.path.join(d, f)) for d, _, fs in os.walk(report) for f in fs)
    print(f"report: {size / 1e6:.1f} MB, index.html {os.path.getsize(os.path.join(report, 'index.html')) / 1e6:.2f} MB")

    index = "file://" + os.path.abspath(os.path.join(report, "index.html"))
    # The list: every clip, no more, and the page ready in under 2 s.
    dom = browse(chromium, index, "--dump-dom")
    attributes, text = status_of(dom)
    if attributes.get("state") != "ready":
        fail(f"the list page is not ready: {attributes} {text}")
    listed = re.findall(r'<td class="name"><a[^>]*>([^<]*)</a>', dom)
    names = sorted(expected)
    if sorted(listed) != names:
        fail(f"the page lists {len(listed)} clips, expected {len(names)}; "
             f"first differences: {sorted(set(listed) ^ set(names))[:3]}")
    load_ms = int(attributes["ms"])
    print(f"list of {len(listed)} clips ready {load_ms} ms after navigation start")
    if load_ms >= 2000:
        fail(f"the {args.clips}-clip page took {load_ms} ms to load (target < 2000)")

    # The player: clip 0 drawn, no error; the screenshot shows both skeletons.
    dom = browse(chromium, index + "#clip=0", "--dump-dom", budget_ms=15000)
    attributes, text = status_of(dom)
    if attributes.get("state") != "drawn":
        fail(f"the player did not draw clip 0: {attributes} {text}")
    shot = os.path.join(WORK, "player.png")
    browse(chromium, index + "#clip=0&layout=side&frame=60", f"--screenshot={shot}", budget_ms=15000)
    image = Image.open(shot).convert("RGB")
    width, height = image.size
    # The 3-D view: left of the 340 px side panel, below the header and its labels, above
    # the transport bar, timeline and curves.
    box = (0, 70, width - 340, height - 270)
    orange = blue = 0
    for r, g, b in image.crop(box).getdata():
        if r > g + 50 and r > b + 50:
            orange += 1
        elif b > r + 50 and b > g + 20:
            blue += 1
    print(f"3-D view {box}: {orange} before (orange) and {blue} after (blue) pixels")
    if orange < 150 or blue < 150:
        fail("the player's view does not show both skeletons (see " + shot + ")")
    print("OK")


if __name__ == "__main__":
    main()
