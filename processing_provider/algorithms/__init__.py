"""One module per algorithm; the parameters and outputs they share are in :mod:`.base`."""
