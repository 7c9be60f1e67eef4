"""widesky.pvsim: cell spectral responses, module model and spectral PV yield (filled by later issues)."""
