"""Simulated flood-rescue USV (software in the loop): plant, disturbances, sensors, hardware seam."""
