"""Control: course and speed controllers (PID baseline and the chapter's active-model scheme, Fig. 6)
and the actuator mapping with saturation flags fed back for anti-windup."""
