"""The ``aerial`` section: quadrotors flying expert trajectories through 3-D corridors, mazes and
rooms (scene ``aerial``, docs/aerial.md)."""

from __future__ import annotations

from dataclasses import dataclass, field

from datagen.config.sections import ranged

# EuRoC's ADIS16448 (its Kalibr imu.yaml): the noise model's defaults
EUROC_IMU = {
    "accelerometer_noise_density": 2.0e-3,  # m/s²/√Hz
    "accelerometer_random_walk": 3.0e-3,  # m/s³/√Hz
    "gyroscope_noise_density": 1.6968e-4,  # rad/s/√Hz
    "gyroscope_random_walk": 1.9393e-5,  # rad/s²/√Hz
}
MAX_STEREO_BASELINE = 0.5  # metres

# degrees above the horizon a forward camera's view may reach: beyond, a drone sees its own
# rotors (datagen/families/aerial/quadrotor.py places its camera pod for this; tested at 4:3)
MAX_CAMERA_TOP_DEG = 45.0


@dataclass(frozen=True)
class ImuNoiseConfig:
    """White noise and a bias random walk per axis, in Kalibr's names and units (continuous-time
    densities; datagen.families.aerial.imu turns them into per-sample values)."""

    enabled: bool = False  # noisy readings beside the ideal ones
    accelerometer_noise_density: float = field(
        default=EUROC_IMU["accelerometer_noise_density"], metadata=ranged(0.0, 1.0, "m/s²/√Hz")
    )
    accelerometer_random_walk: float = field(
        default=EUROC_IMU["accelerometer_random_walk"], metadata=ranged(0.0, 1.0, "m/s³/√Hz")
    )
    gyroscope_noise_density: float = field(
        default=EUROC_IMU["gyroscope_noise_density"], metadata=ranged(0.0, 1.0, "rad/s/√Hz")
    )
    gyroscope_random_walk: float = field(
        default=EUROC_IMU["gyroscope_random_walk"], metadata=ranged(0.0, 1.0, "rad/s²/√Hz")
    )


@dataclass(frozen=True)
class AerialConfig:
    family: str = "corridor"  # a floor-plan family (navigation layouts), raised into 3-D
    drones: int = field(default=1, metadata=ranged(1, 8, "drones flying at once in one episode"))
    span: tuple[float, float] = field(
        default=(0.25, 0.45), metadata=ranged(0.1, 1.0, "metres between opposite rotor centres")
    )
    airframe: str = "quadrotor"  # a drone's frame (datagen.registries.AIRFRAMES)
    # the volume (datagen.families.aerial.volumes)
    height: tuple[float, float] = field(
        default=(2.6, 4.0), metadata=ranged(1.0, 10.0, "floor to ceiling, metres")
    )
    voxel_size: float = field(default=0.1, metadata=ranged(0.02, 0.5, "occupancy voxel side, m"))
    pillars: tuple[int, int] = field(
        default=(0, 3), metadata=ranged(0, 20, "floor-to-ceiling posts")
    )
    beams: tuple[int, int] = field(default=(0, 2), metadata=ranged(0, 20, "bars across a passage"))
    hanging: tuple[int, int] = field(
        default=(0, 2), metadata=ranged(0, 20, "boxes hanging from the ceiling")
    )
    screens: tuple[int, int] = field(
        default=(0, 1), metadata=ranged(0, 10, "walls across a passage with one opening")
    )
    window_probability: float = field(
        default=0.5, metadata=ranged(0.0, 1.0, "chance per inner wall of rooms: an opening")
    )
    # the expert (datagen.families.aerial.planning)
    margin: float = field(
        default=0.15, metadata=ranged(0.0, 1.0, "clearance beyond the drone's radius, metres")
    )
    min_goal_distance: float = field(
        default=3.0, metadata=ranged(0.0, 50.0, "straight-line start-goal distance, metres")
    )
    max_speed: float = field(default=1.5, metadata=ranged(0.1, 20.0, "m/s"))
    max_acceleration: float = field(default=2.5, metadata=ranged(0.1, 30.0, "m/s², piece times"))
    max_thrust: float = field(
        default=20.0, metadata=ranged(10.0, 60.0, "mass-normalised collective thrust, m/s²")
    )
    min_thrust: float = field(default=4.0, metadata=ranged(0.5, 9.8, "m/s²"))
    max_body_rate: float = field(default=3.0, metadata=ranged(0.1, 20.0, "rad/s"))
    goal_tolerance: float = field(default=0.2, metadata=ranged(0.01, 2.0, "metres"))
    # frames and cameras
    frame_rate_hz: float = field(
        default=5.0, metadata=ranged(0.1, 100.0, "rendered frames per simulated second")
    )
    camera_fovy_deg: tuple[float, float] = field(
        default=(60.0, 75.0), metadata=ranged(10.0, 150.0, "forward camera, degrees")
    )
    camera_pitch_deg: tuple[float, float] = field(
        default=(-20.0, 5.0), metadata=ranged(-60.0, 60.0, "forward camera tilt up, degrees")
    )
    down_camera: bool = False  # also a camera looking straight down
    down_fovy_deg: tuple[float, float] = field(
        default=(60.0, 90.0), metadata=ranged(10.0, 150.0, "downward camera, degrees")
    )
    optical_flow: bool = True  # flow to the next frame per camera (KITTI 16-bit PNG)
    stereo_baseline: float = field(
        default=0.0,
        metadata=ranged(0.0, MAX_STEREO_BASELINE, "metres to a right camera; 0 = none"),
    )
    # the IMU stream (datagen.families.aerial.imu)
    imu_hz: float = field(default=200.0, metadata=ranged(10.0, 2000.0, "IMU samples per second"))
    imu_noise: ImuNoiseConfig = field(default_factory=ImuNoiseConfig)
