"""Vehicle modes: one class per file, listed once in :data:`companion.modes.manager.MODE_CLASSES`."""
