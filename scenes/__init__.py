"""The scene language: typed, validated scene specs and camera geometry (numpy only)."""
from .camera import CAMERA_KINDS, Camera
from .loader import PALETTE, SceneError, bundled_scenes, load_scene, parse_scene, resolve_scene_path, scene_sha256, scene_toml
from .spec import Floorplan, GaussMarkovParams, Obstacle, Scene, SensorSpec, Wall, WalkerSpec

__all__ = [
    "CAMERA_KINDS", "Camera", "PALETTE", "SceneError", "bundled_scenes", "load_scene", "parse_scene",
    "resolve_scene_path", "scene_sha256", "scene_toml", "Floorplan", "GaussMarkovParams", "Obstacle", "Scene", "SensorSpec", "Wall", "WalkerSpec",
]
