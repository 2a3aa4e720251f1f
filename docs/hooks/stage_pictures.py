"""MkDocs hook: the pipeline detector's stage pictures, drawn from the code at build time.

:func:`marknav.vision.detect.pictures.stage_pictures` runs the pipeline on its drawn scene; each
stage's picture becomes the site file ``explanation/detector-stages/<stage>.png``, which the
detector page shows.
"""

from __future__ import annotations

from typing import Any

from mkdocs.structure.files import File, Files

FOLDER = "explanation/detector-stages"


def on_files(files: Files, config: Any, **_kwargs: Any) -> Files:
    from marknav.vision.detect.pictures import stage_pictures

    for name, png in stage_pictures().items():
        files.append(File.generated(config, f"{FOLDER}/{name}.png", content=png))
    return files
