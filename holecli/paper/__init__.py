"""The published method (Khazali et al.), kept as the paper describes it with its errata corrected:
the whole pipeline in :mod:`.method`, its rim segmentation in :mod:`.rim`."""
