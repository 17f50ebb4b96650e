"""Quality records of a lot of measurements: the inspection report, control charts, QIF and first-article tables.

:mod:`holecli.quality.lot` turns detect/batch records into a :class:`~holecli.quality.lot.Lot` of
checked characteristics; the other modules turn a lot into a record the quality office keeps. Pure:
records in, text out; reading files and stores is :mod:`holecli.cli.report`'s.
"""
