"""The dashboard camera: world raster, pinhole geometry, rendering with ground truth."""

from simroad.camera.bev import render_bev
from simroad.camera.codes import ASPHALT, MARKING, ROADSIDE, SHOULDER, SKY, VEHICLE
from simroad.camera.geometry import CameraConfig, PinholeCamera
from simroad.camera.render import CameraRenderer, Frame
from simroad.camera.sensor import Sensor
from simroad.camera.sensor_params import SensorParams
from simroad.camera.vehicles import VehicleBox
from simroad.camera.world import WorldRaster

__all__ = [
    "ASPHALT",
    "MARKING",
    "ROADSIDE",
    "SHOULDER",
    "SKY",
    "VEHICLE",
    "CameraConfig",
    "CameraRenderer",
    "Frame",
    "PinholeCamera",
    "Sensor",
    "SensorParams",
    "VehicleBox",
    "WorldRaster",
    "render_bev",
]
