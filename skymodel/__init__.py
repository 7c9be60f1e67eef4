"""widesky.skymodel: the wide-spectral-range Prague Sky Model (reader, evaluator, renderer)."""
