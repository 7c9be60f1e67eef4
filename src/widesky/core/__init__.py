"""The core layer: data paths and helpers shared by every widesky package.

It is the lowest layer: nothing here imports from widesky's other packages (``skymodel``,
``irradiance``, ``pvsim``, ``thermal``, ``cases``, the command line).
"""
