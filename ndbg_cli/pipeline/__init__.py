"""The stages composed: ``find_contacts -> build_ndbg -> measure -> plan_assembly``
(:mod:`.stages`), ``analyze`` (:mod:`.analysis`) and batches (:mod:`.batch`)."""
