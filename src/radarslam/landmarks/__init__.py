"""Landmark management of APSIPA 2022 (docs/method.md section c): sifting, association, clustering,
confirmation (Rule 1 / Rule 2), M/N removal and merging."""
