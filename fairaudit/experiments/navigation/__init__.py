"""Robot navigation plug-in: S3DIS scans, maps, routes through the rooms and route images (extra ``fairness-certify[navigation]``).

The map pipeline of the paper's Methods, on point clouds in the S3DIS format
(Armeni et al. 2016):

* :mod:`~fairaudit.experiments.navigation.s3dis`: :func:`read_room`, :func:`read_area`,
  :func:`iter_rooms` (one room at a time);
* :mod:`~fairaudit.experiments.navigation.synthetic`: :func:`write_office_floor`, a
  small office floor in that format, with one hallway or two corridors (S3DIS
  itself is not shipped);
* :mod:`~fairaudit.experiments.navigation.maps`: :func:`build_maps`, the top-view,
  traversability and topological maps on one grid (from an Area, or streamed
  room by room from its folder);
* :mod:`~fairaudit.experiments.navigation.topology`: the doors the robot can
  pass (:func:`find_doors`), the graph of rooms joined by them
  (:func:`passable_graph`) and room paths realised on the grid
  (:func:`door_paths`);
* :mod:`~fairaudit.experiments.navigation.routes`: candidate routes through the
  topological map (:func:`route_alternatives`, :func:`candidate_routes`), plain
  A* routes (:func:`plan_route`), the equal-distance check and
  :func:`delivery_scene`, all of it in one call;
* :mod:`~fairaudit.experiments.navigation.images`: the route images (:func:`route_image`), framed on the
  routes (:func:`route_window`).

networkx (A*, topology) and pillow (images) are imported only by the functions
that need them.
"""

from .images import GOAL_RGB, ROUTE_MARGIN, ROUTE_RGB, START_RGB, route_image, route_window
from .maps import CEILING_MARGIN, Maps, build_maps
from .routes import (
    MAX_SNAP,
    DeliveryScene,
    DistanceCheck,
    Route,
    candidate_routes,
    check_equal_distance,
    delivery_scene,
    plan_route,
    route_alternatives,
)
from .s3dis import (
    CATEGORIES,
    UNLABELLED,
    Area,
    Room,
    iter_rooms,
    read_area,
    read_points,
    read_room,
    room_kind,
)
from .synthetic import LAYOUTS, write_office_floor
from .topology import Door, DoorPath, door_paths, find_doors, passable_graph

__all__ = [
    "CATEGORIES",
    "CEILING_MARGIN",
    "GOAL_RGB",
    "LAYOUTS",
    "MAX_SNAP",
    "ROUTE_MARGIN",
    "ROUTE_RGB",
    "START_RGB",
    "UNLABELLED",
    "Area",
    "DeliveryScene",
    "DistanceCheck",
    "Door",
    "DoorPath",
    "Maps",
    "Room",
    "Route",
    "build_maps",
    "candidate_routes",
    "check_equal_distance",
    "delivery_scene",
    "door_paths",
    "find_doors",
    "iter_rooms",
    "passable_graph",
    "plan_route",
    "read_area",
    "read_points",
    "read_room",
    "room_kind",
    "route_alternatives",
    "route_image",
    "route_window",
    "write_office_floor",
]
