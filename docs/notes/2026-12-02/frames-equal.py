"""Session 7 notes: does a checkout render the same frames? Every frame of ``marknav bench
loop`` (the slalom, 817 frames) hashed, for the ``marknav`` package exported to DIR.

Usage (from the project root, with the project's venv active)::

    mkdir -p /tmp/old && git archive fe224e8 marknav missions | tar -x -C /tmp/old
    python docs/notes/2026-12-02/frames-equal.py /tmp/old
    python docs/notes/2026-12-02/frames-equal.py "$PWD"

Prints the number of frames and a SHA-256 prefix of all of them (the timing figures it also
prints are slowed by the hashing).
"""

from __future__ import annotations

import hashlib
import json
import sys
from typing import Any


def main(root: str) -> None:
    sys.path.insert(0, root)
    import marknav

    assert marknav.__file__ is not None and marknav.__file__.startswith(root), marknav.__file__
    import marknav.sim.camera as camera
    from marknav.runs.bench import bench_loop

    digest = hashlib.sha256()
    count = [0]
    original = camera.Renderer.render

    def render(self: Any, pose: Any, rng: Any = None) -> Any:
        image = original(self, pose, rng)
        digest.update(image.tobytes())
        count[0] += 1
        return image

    camera.Renderer.render = render  # type: ignore[method-assign]
    loop = bench_loop()
    print(json.dumps({"frames": count[0], "sha256": digest.hexdigest()[:16],
                      "speedup": loop["speedup"]}))


if __name__ == "__main__":
    if len(sys.argv) != 2:
        sys.exit(__doc__)
    main(sys.argv[1])
