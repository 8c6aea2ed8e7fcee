"""Regenerate the examples gallery: docs/img/gallery/*.png and docs/gallery.md.

Runs every script in examples/ as a user would, ``python examples/NAME.py
--plot FILE`` (with the options in ``OPTIONS``), scales its figure to about
90 dpi and writes it as a small palette PNG (an octree palette of 256 colours),
then writes docs/gallery.md from the examples' docstrings.  Run it after
changing an example or a plot, look at the pictures, and commit them::

    python docs/make_gallery.py              # every example (several minutes)
    python docs/make_gallery.py rolling_disk # some of them; gallery.md lists all

The page is static (the pictures are committed), so building the docs does not
run the examples.
"""

import argparse
import ast
import re
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
EXAMPLES = ROOT / "examples"
OUT = ROOT / "docs" / "img" / "gallery"
PAGE = ROOT / "docs" / "gallery.md"

#: extra command-line options of an example for the gallery run
OPTIONS = {}
#: the examples save at 120 dpi; the gallery shows them at 120 * SCALE dpi
SCALE = 0.75


def docstring(path):
    """The example's module docstring: (title, what it shows).

    The title is the first paragraph; what it shows is the next one, with the
    list that follows it when it ends with a colon (kept as a markdown list)."""
    text = ast.get_docstring(ast.parse(path.read_text())) or path.stem
    paragraphs = [p.strip("\n") for p in text.split("\n\n")]
    title = " ".join(paragraphs[0].split())
    body = []
    for paragraph in paragraphs[1:]:
        is_item = re.match(r"\s*(\*|-|\d+\.)\s", paragraph)
        if body and not is_item and not body[-1].rstrip().endswith(":"):
            break
        if paragraph.lstrip().startswith(("Run", "python ")):
            continue
        body.append(paragraph if is_item else " ".join(paragraph.split()))
    return title, "\n\n".join(body)


def render(name):
    """Run ``examples/<name>.py --plot`` and write ``OUT/<name>.png``; seconds taken."""
    from PIL import Image

    with tempfile.TemporaryDirectory() as tmp:
        raw = Path(tmp) / f"{name}.png"
        start = time.perf_counter()
        subprocess.run([sys.executable, str(EXAMPLES / f"{name}.py"), *OPTIONS.get(name, []),
                        "--plot", str(raw)], cwd=tmp, check=True,
                       stdout=subprocess.DEVNULL)
        seconds = time.perf_counter() - start
        with Image.open(raw) as image:
            image = image.convert("RGB")
            size = (round(image.width * SCALE), round(image.height * SCALE))
            # an octree palette of 256 keeps every curve its own colour (a median cut
            # of 128 merged the colours of the ten curves of formulations_compared)
            small = image.resize(size, Image.LANCZOS).quantize(
                colors=256, method=Image.Quantize.FASTOCTREE)
            OUT.mkdir(parents=True, exist_ok=True)
            small.save(OUT / f"{name}.png", optimize=True)
    return seconds


def write_page(names):
    lines = ["# Gallery", "",
             "The scripts in `examples/`, one concept each, and the figure each saves with",
             "`--plot`. Run one with `python examples/NAME.py --plot NAME.png`;",
             "`tests/test_examples.py` runs every one and checks the numbers it prints",
             "against independent references. The pictures are made by",
             "`python docs/make_gallery.py`.", ""]
    for name in names:
        title, body = docstring(EXAMPLES / f"{name}.py")
        lines += [f"## {name}.py", "", title, ""]
        if body:
            lines += [body, ""]
        if (OUT / f"{name}.png").exists():
            lines += [f"![{name}](img/gallery/{name}.png)", ""]
    PAGE.write_text("\n".join(lines))


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("names", nargs="*", help="examples to run (default: all)")
    parser.add_argument("--page-only", action="store_true",
                        help="only rewrite gallery.md from the docstrings")
    args = parser.parse_args(argv)
    every = sorted(path.stem for path in EXAMPLES.glob("*.py"))
    unknown = sorted(set(args.names) - set(every))
    if unknown:
        parser.error(f"no such example: {', '.join(unknown)} (examples: {', '.join(every)})")
    if not args.page_only:
        for name in args.names or every:
            seconds = render(name)
            kb = (OUT / f"{name}.png").stat().st_size / 1024
            print(f"{name:24s} {seconds:6.1f} s  {kb:5.0f} kB", flush=True)
    write_page(every)


if __name__ == "__main__":
    main()
