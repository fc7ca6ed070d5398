"""Types and infrastructure every stage shares: the assembly model, errors, options, the
family names and tolerances, atomic files, the per-pair cache, progress and process pools."""
