"""`python -m datagen.engines.sim.render_probe`: exits 0 and names the device when SAPIEN can render."""

import sys


def main() -> int:
    import sapien

    from datagen.engines.sim.brdf_lut import attach_brdf_lut

    scene = sapien.Scene()
    camera = scene.add_camera("probe", 8, 8, 1.0, 0.01, 10.0)
    attach_brdf_lut(camera)  # the first run on a machine reads SAPIEN's table back and caches it
    scene.update_render()
    camera.take_picture()
    camera.get_picture("Color")
    device = sapien.render.get_device_summary().strip().splitlines()
    print(device[0] if device else "a Vulkan device")
    return 0


if __name__ == "__main__":
    sys.exit(main())
