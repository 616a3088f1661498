"""The boat's payloads: the pneumatic rope launcher and the four-bottle water sampler.

A payload is one module (or package) here that defines ``PAYLOAD``
(:class:`~companion.payloads.registry.PayloadDef`): its parameters, commands, mission items,
servo outputs, status messages, sentences and dialect entries.  The registry
(:mod:`.registry`) finds them and wires them into the vehicle; nothing else names a payload.
Shared by the launcher and the sampler: the durable sample/launch log (:mod:`.samplelog`), their
outputs and sensor messages (:mod:`.topics`) and the helpers of their upload checks
(:mod:`.mission_checks`).
"""
