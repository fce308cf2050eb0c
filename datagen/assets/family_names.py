"""The names of the shape and texture families the builders make, with no geometry imported: the config
validates against them in every process, including ones that never build a mesh."""

# the household shape families; each is built along the object frame's axes, so the
# axis-aligned box is its tight oriented box
HOUSEHOLD_FAMILIES = ("bottle", "can", "mug", "bowl", "lidded_box", "tool")

# the procedural texture families of datagen/assets/texture_tiles.py
TEXTURE_FAMILIES = ("noise", "stripes", "checker", "marble", "grain", "speckle")
