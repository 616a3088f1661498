"""The boat's payloads: the pneumatic rope launcher and the four-bottle water sampler.

One file per payload (:mod:`.launcher`, :mod:`.sampler`), the durable log both write
(:mod:`.samplelog`), their parameters (:mod:`.params`), the MAVLink command handlers
(:mod:`.commands`), the service that runs them (:mod:`.service`) and the API the AUTO mode
calls for the dialect's mission items (:mod:`.registry`).
"""
