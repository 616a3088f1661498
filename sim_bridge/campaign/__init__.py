"""Monte-Carlo campaigns: missions and manoeuvres across currents, wind, waves and seeds, on Dask
(``usv campaign run`` / ``usv campaign report``; campaign files in ``campaigns/``)."""
