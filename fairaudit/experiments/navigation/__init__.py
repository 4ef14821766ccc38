"""Robot navigation plug-in: S3DIS scans, maps, A* routes and route images (extra ``fairaudit[navigation]``).

The map pipeline of the paper's Methods, on point clouds in the S3DIS format
(Armeni et al. 2016):

* :mod:`~fairaudit.experiments.navigation.s3dis`: :func:`read_room`, :func:`read_area`;
* :mod:`~fairaudit.experiments.navigation.synthetic`: :func:`write_office_floor`, a
  small office floor in that format (S3DIS itself is not shipped);
* :mod:`~fairaudit.experiments.navigation.maps`: :func:`build_maps`, the top-view,
  traversability and topological maps on one grid;
* :mod:`~fairaudit.experiments.navigation.routes`: A* routes (:func:`plan_route`,
  :func:`candidate_routes`), the equal-distance check and :func:`delivery_scene`,
  all of it in one call;
* :mod:`~fairaudit.experiments.navigation.images`: the route images (:func:`route_image`).

networkx (A*, topology) and pillow (images) are imported only by the functions
that need them.
"""

from .images import ROUTE_RGB, route_image, save_route_image
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
)
from .s3dis import CATEGORIES, UNLABELLED, Area, Room, category_code, read_area, read_points, read_room, room_kind
from .synthetic import write_office_floor

__all__ = [
    "CATEGORIES",
    "CEILING_MARGIN",
    "MAX_SNAP",
    "ROUTE_RGB",
    "UNLABELLED",
    "Area",
    "DeliveryScene",
    "DistanceCheck",
    "Maps",
    "Room",
    "Route",
    "build_maps",
    "candidate_routes",
    "category_code",
    "check_equal_distance",
    "delivery_scene",
    "plan_route",
    "read_area",
    "read_points",
    "read_room",
    "room_kind",
    "route_image",
    "save_route_image",
    "write_office_floor",
]
