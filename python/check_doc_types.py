"""mypy --strict on the Python examples of the docs (every ```python block, in order, as one
program) against the module's stub sombra.pyi in STUB_DIR (issue 26). ctest runs it on
docs/python.md with .python-deps' mypy; usage: python3 python/check_doc_types.py STUB_DIR DOCS.md…"""
import os
import re
import sys
import tempfile
from pathlib import Path

from mypy import api


def main():
    stub_dir, docs = sys.argv[1], sys.argv[2:]
    blocks = []
    for doc in docs:
        blocks += re.findall(r"```python\n(.*?)```", Path(doc).read_text(), flags=re.S)
    if not blocks:
        sys.exit("check_doc_types: no ```python block in " + ", ".join(docs))
    os.environ["MYPYPATH"] = stub_dir  # the stub, not the compiled module (mypy cannot read a .so)
    with tempfile.TemporaryDirectory() as folder:
        program = Path(folder) / "doc_examples.py"
        program.write_text("\n".join(blocks))
        stdout, stderr, status = api.run(
            ["--strict", "--no-incremental", "--cache-dir", str(Path(folder) / "cache"), "--python-version", "3.11", str(program)]
        )
    print(f"check_doc_types: {len(blocks)} blocks from {', '.join(docs)}")
    print(stdout, end="")
    print(stderr, end="", file=sys.stderr)
    sys.exit(status)


if __name__ == "__main__":
    main()
