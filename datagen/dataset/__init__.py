"""Reading a dataset: map-style and streaming loaders, and every sample's labelled views in one
shape. Needs neither the simulator nor a broker."""
