"""Pictures of a report: the offline HTML report (:mod:`.html`), the exploded glTF binary
(:mod:`.glb`) and the static images for CI artefacts (:mod:`.static`).

Each takes a finished report dict and the loaded :class:`~ndbg_cli.core.assembly.Assembly`
(for the meshes) and never analyses anything again: what is drawn is what the report says.
The shared data are in :mod:`._scene` (part meshes for display, colours, the plan's exploded
poses), :mod:`.sphere` (the direction sphere of each family, coloured by DBG) and
:mod:`.tree` (the plan's assembly tree laid out). plotly and matplotlib are imported only
here, when a picture is asked for.
"""
