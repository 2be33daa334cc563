"""Importing numpy + Open3D for the peer benchmarks, with one clear error when they are missing.

Debian's python3-open3d lives in /usr/lib/python3/dist-packages, which a pyenv or venv python does
not see; the message says so instead of a bare ImportError.
"""
import sys


def import_np_o3d(tool):
    """Return (numpy, open3d), or exit 2 with an error line prefixed by `tool`."""
    try:
        import numpy as np
        import open3d as o3d
    except ImportError as e:
        print(f"{tool}: error: cannot import open3d/numpy with {sys.executable} ({e}). On Debian: "
              "apt-get install python3-open3d, and run this script with /usr/bin/python3 (not a "
              "pyenv/venv python).", file=sys.stderr)
        sys.exit(2)
    return np, o3d
