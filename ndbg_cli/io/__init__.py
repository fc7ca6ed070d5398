"""Load and validate: the loader registry (manifests, STEP, 3DXML, GLB, meshes), manifests,
validation and repair of parts, config files, conversion to meshes plus a manifest."""
