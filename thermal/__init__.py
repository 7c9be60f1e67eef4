"""widesky.thermal: facade solar gains and hourly zone loads (filled by later issues)."""
