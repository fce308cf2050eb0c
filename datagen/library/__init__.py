"""The library of real appearance: photographs, material scans and meshes fetched from the
package registries by ``datagen library install`` into a cache (never the repository), each
file with its source and licence in the cache's ``manifest.json``."""
