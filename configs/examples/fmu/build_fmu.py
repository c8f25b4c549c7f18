"""Build first_order.fmu (FMI 2.0 co-simulation, this platform) from first_order.c and
modelDescription.xml, with a C compiler and the FMI 2 headers that fmpy ships.

    .venv/bin/python configs/examples/fmu/build_fmu.py [OUT_DIR]   # writes OUT_DIR/first_order.fmu
"""

from __future__ import annotations

import pathlib
import shutil
import subprocess
import sys
import tempfile
import zipfile

HERE = pathlib.Path(__file__).resolve().parent


def build(out_dir: str | pathlib.Path = HERE) -> pathlib.Path:
    """Compile and zip the FMU; returns its path (RuntimeError without fmpy or a C compiler)."""
    try:
        import fmpy
        from fmpy import platform
    except ImportError:
        raise RuntimeError("fmpy is not installed (pip install -e '.[fmu]')") from None
    cc = shutil.which("cc") or shutil.which("gcc")
    if cc is None:
        raise RuntimeError("no C compiler (cc or gcc) on PATH")
    headers = pathlib.Path(fmpy.__file__).parent / "c-code"
    out = pathlib.Path(out_dir) / "first_order.fmu"
    with tempfile.TemporaryDirectory() as d:
        so = pathlib.Path(d) / "first_order.so"
        subprocess.run([cc, "-shared", "-fPIC", "-O2", f"-I{headers}", str(HERE / "first_order.c"), "-o", str(so),
                        "-lm"], check=True, capture_output=True)
        with zipfile.ZipFile(out, "w") as z:
            z.write(HERE / "modelDescription.xml", "modelDescription.xml")
            z.write(so, f"binaries/{platform}/first_order.so")
            z.write(HERE / "first_order.c", "sources/first_order.c")
    return out


if __name__ == "__main__":
    print(build(sys.argv[1] if len(sys.argv) > 1 else HERE))
