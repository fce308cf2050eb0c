"""`python -m datagen.sensing.render_probe`: exits 0 and names the device when SAPIEN can render."""

import sys


def main() -> int:
    import sapien

    from datagen.sensing.render import keep_renderer_alive

    keep_renderer_alive()  # renders a frame; the first run on a machine caches the BRDF table
    device = sapien.render.get_device_summary().strip().splitlines()
    print(device[0] if device else "a Vulkan device")
    return 0


if __name__ == "__main__":
    sys.exit(main())
