"""Campaigns: many randomised flights from one campaign file, on all local cores or a Ray cluster.

``campaign run FILE`` / ``campaign report RESULTS`` (:mod:`.__main__`).  One module per job:

- :mod:`.spec`: the campaign file (TOML), checked key by key;
- :mod:`.kinds`: what a run flies (``landing``: :mod:`.landing`; ``hover_step``: :mod:`.hover_step`;
  ``mission``: :mod:`.mission_kind`), its grid axes, ranges, figures;
- :mod:`.plan`: the grid's cells and each run's deterministic seeds and draws;
- :mod:`.runs`: one run on its own stack and leased instance, its status, retries of infrastructure failures;
- :mod:`.executors`: the local process pool and Ray;
- :mod:`.results`: the CSV, appended as runs end, and resuming from it;
- :mod:`.runner`: ties them together with the progress bar;
- :mod:`.report`, :mod:`.plots`: the table per cell (Wilson intervals) and the PNGs.
"""
