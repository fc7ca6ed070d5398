"""The pictures of ``ndbg analyze`` (``--html``, ``--glb``, ``--png``, ``--svg``): where each
goes, and writing them once a report is done. :mod:`ndbg_cli.pictures` is imported only when
a picture is asked for.

For one assembly ``--html``/``--glb`` name a file and ``--png``/``--svg`` a folder; in a batch
(several assemblies, or ``--out-dir``) ``--html``/``--glb`` name a folder holding one
``NAME.html``/``NAME.glb`` per assembly (``--html`` also an ``index.html`` linking them with
their verdicts), and ``--png``/``--svg`` one subfolder ``NAME/`` each. ``NAME`` is the stem of
the report's JSON file under ``--out-dir``.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

from ..core.files import write_atomic
from ..core.options import Options
from ._app import cannot_write, check_writable

if TYPE_CHECKING:  # the CLI starts without numpy (tests/test_architecture.py)
    from ..core.assembly import Assembly


@dataclass
class Pictures:
    """The pictures asked for (paths as given, ``None``: not asked) and, in a batch, the
    pages written so far for ``index.html``."""

    html: str | None = None
    glb: str | None = None
    png: str | None = None
    svg: str | None = None
    batch: bool = False
    pages: list[tuple[dict, str | None]] = field(default_factory=list)
    #: assemblies loaded by the analysis in this process, by path, until their pictures
    loaded: dict[Path, Assembly] = field(default_factory=dict)

    def keep(self, path: Path, asm: Assembly) -> None:
        """Keep an assembly the analysis loaded here, for its pictures (``on_loaded``)."""
        self.loaded[path] = asm

    @property
    def wanted(self) -> bool:
        return any((self.html, self.glb, self.png, self.svg))

    def check(self) -> None:
        """Every output place writable before the analysis starts (an input error if not)."""
        for where, is_dir in ((self.html, self.batch), (self.glb, self.batch),
                              (self.png, True), (self.svg, True)):
            if where:
                check_writable(where, Path(where) if is_dir else Path(where).parent)

    def write(self, report: dict, target: Path, stem: str, options: Options) -> None:
        """Write the pictures of one finished report (none for an error record)."""
        if not self.wanted:
            return
        if "error" in report:
            self.loaded.pop(target, None)
            self.pages.append((report, None))
            return
        asm = self.loaded.pop(target, None) or _load(target, options)
        if self.html:
            from ..pictures.html import render_html

            path = Path(self.html) / f"{stem}.html" if self.batch else Path(self.html)
            _write(self.html, path, render_html(report, asm))
            self.pages.append((report, path.name))
        if self.glb:
            from ..pictures.glb import glb_bytes

            path = Path(self.glb) / f"{stem}.glb" if self.batch else Path(self.glb)
            _write(self.glb, path, glb_bytes(report, asm))
        for where, fmt in ((self.png, "png"), (self.svg, "svg")):
            if where:
                from ..pictures.static import write_images

                folder = Path(where) / stem if self.batch else Path(where)
                try:
                    write_images(report, asm, folder, fmt)
                except OSError as exc:
                    raise cannot_write(where, exc) from None

    def finish(self) -> None:
        """A batch's ``index.html`` (when ``--html`` was asked), after every report."""
        if self.html and self.batch:
            from ..pictures.html import index_html

            _write(self.html, Path(self.html) / "index.html", index_html(self.pages))


def _load(target: Path, options: Options) -> Assembly:
    """The assembly of ``target`` read again, the way the analysis read it (the report keeps
    no meshes; an assembly analysed in a worker process is not sent back)."""
    from ..io.loaders import load

    return load(target, units=options.units, tolerance=options.tolerance,
                allow_outside_paths=options.allow_outside_paths,
                mesh_tolerance=options.mesh_tolerance, load_timeout=options.load_timeout,
                load_memory=options.load_memory, max_triangles=options.max_triangles)


def _write(where: str, path: Path, data: str | bytes) -> None:
    try:
        write_atomic(path, data)
    except OSError as exc:
        raise cannot_write(where, exc) from None
