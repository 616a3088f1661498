"""MAVSDK-Python mission scripts for the boat: rescue rope throw, water sampling."""
