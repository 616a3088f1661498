"""GPS-INS health: fault detection on each sample (:mod:`.detector`) and the degraded action
(:mod:`.stage`, the pipeline's NavHealth stage)."""
