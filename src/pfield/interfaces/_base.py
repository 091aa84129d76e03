"""Base class and field types of the pydantic models that mirror ROS 2 ``.msg``/``.srv`` files.

Every message model derives from :class:`RosMessage`: unknown fields are errors, missing fields take the
ROS default (0, empty string, false, empty array, default-constructed nested message). Field types are
ROS's: a float field takes a number (an int too, as ros2's YAML arguments allow), an integer field an int,
a bool field true or false. A string or a boolean where a number belongs is refused (pydantic alone would
read ``"0.02"`` as 0.02 and ``True`` as 1), and so is a float or a string where an integer or a boolean
belongs. Each model declares its ROS type name (``ros_type = "geometry_msgs/msg/Pose"``) and is registered
under it, so transports can look a type up by the name a user types on the command line. Field annotations
carry the ROS primitive type (``Float32`` …) so a test can prove the models equal the ``.msg`` files.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Annotated, Any, ClassVar

from pydantic import AfterValidator, BaseModel, BeforeValidator, ConfigDict, Field

from pfield import _validation
from pfield.errors import InvalidInput

__all__ = [
    "Bool",
    "Float32",
    "Float64",
    "Int8",
    "Int16",
    "Int32",
    "Int64",
    "RosMessage",
    "RosType",
    "ServiceType",
    "String",
    "UInt8",
    "UInt16",
    "UInt32",
    "UInt64",
    "lookup_service",
    "lookup_type",
    "registered_services",
    "registered_types",
]


@dataclass(frozen=True)
class RosType:
    """Annotation metadata: the ROS primitive type name of a field (``float32``, ``uint8`` …)."""

    name: str


FLOAT32_MAX = 3.4028234663852886e38
"""Largest finite float32: a finite value beyond it is refused, as rclpy's generated setters refuse it
(``inf`` and ``NaN`` pass, as in ROS, and are judged by the node)."""


def _utf8(value: str) -> str:
    try:
        return _validation.text("string", value)
    except InvalidInput as exc:  # pydantic names the field; the reason says what is wrong
        raise ValueError(f"{exc.value}: {exc.reason}") from None


def _float32(value: float) -> float:
    if abs(value) > FLOAT32_MAX and value not in (float("inf"), float("-inf")):
        raise ValueError(f"{value!r} is outside the float32 range (|x| <= {FLOAT32_MAX:.7g})")
    return value


def _typed(check: Any) -> BeforeValidator:
    """A pydantic check of the value's own type by ``check`` (one of :mod:`pfield._validation`'s), before
    pydantic's conversions could read a string or a boolean as a number."""

    def validate(value: Any) -> Any:
        try:
            return check("value", value)
        except InvalidInput as exc:  # pydantic names the field
            raise ValueError(exc.reason) from None

    return BeforeValidator(validate)


_NUMBER = _typed(_validation.number)
_INTEGER = _typed(_validation.integer)

Bool = Annotated[bool, _typed(_validation.boolean), RosType("bool")]
String = Annotated[str, AfterValidator(_utf8), RosType("string")]
"""A ROS string: valid UTF-8 (a lone surrogate such as ``"\\ud800"`` is refused naming the field)."""
Float32 = Annotated[float, _NUMBER, AfterValidator(_float32), RosType("float32")]
Float64 = Annotated[float, _NUMBER, RosType("float64")]
Int8 = Annotated[int, _INTEGER, Field(ge=-(2**7), lt=2**7), RosType("int8")]
Int16 = Annotated[int, _INTEGER, Field(ge=-(2**15), lt=2**15), RosType("int16")]
Int32 = Annotated[int, _INTEGER, Field(ge=-(2**31), lt=2**31), RosType("int32")]
Int64 = Annotated[int, _INTEGER, Field(ge=-(2**63), lt=2**63), RosType("int64")]
UInt8 = Annotated[int, _INTEGER, Field(ge=0, lt=2**8), RosType("uint8")]
UInt16 = Annotated[int, _INTEGER, Field(ge=0, lt=2**16), RosType("uint16")]
UInt32 = Annotated[int, _INTEGER, Field(ge=0, lt=2**32), RosType("uint32")]
UInt64 = Annotated[int, _INTEGER, Field(ge=0, lt=2**64), RosType("uint64")]

_REGISTRY: dict[str, type[RosMessage]] = {}


class RosMessage(BaseModel):
    """A ROS message (or service request/response) as a strict pydantic model."""

    model_config = ConfigDict(extra="forbid", validate_assignment=True, populate_by_name=True,
                              ser_json_inf_nan="constants")

    ros_type: ClassVar[str] = ""
    """Full ROS type name, e.g. ``geometry_msgs/msg/Pose`` or ``pkg/srv/Name_Request``."""
    ros_constants: ClassVar[dict[str, tuple[str, Any]]] = {}
    """Constants declared in the interface file: name -> (ROS type, value)."""

    def __init_subclass__(cls, **kwargs: Any) -> None:
        super().__init_subclass__(**kwargs)
        name = cls.__dict__.get("ros_type", "")
        if name:
            _REGISTRY[name] = cls


def registered_types() -> dict[str, type[RosMessage]]:
    """All registered message types by ROS name (``pkg/msg/Name``; services as ``pkg/srv/Name_Request``)."""
    return dict(_REGISTRY)


def lookup_type(name: str) -> type[RosMessage]:
    """Model class for a ROS type name; ``pkg/Name`` is accepted for ``pkg/msg/Name`` as ``ros2`` does."""
    if name in _REGISTRY:
        return _REGISTRY[name]
    if name in _REGISTRY:
        return _REGISTRY[name]
    parts = name.split("/")
    if len(parts) == 2 and f"{parts[0]}/msg/{parts[1]}" in _REGISTRY:
        return _REGISTRY[f"{parts[0]}/msg/{parts[1]}"]
    raise InvalidInput("type", name, "unknown message type (`pfield interface list` lists the known ones)")


@dataclass(frozen=True)
class ServiceType:
    """A ROS service type: ``name`` (``pkg/srv/Name``) with its request and response models."""

    name: str
    request: type[RosMessage]
    response: type[RosMessage]


def registered_services() -> dict[str, ServiceType]:
    """Every service whose ``_Request`` and ``_Response`` models are registered, by ``pkg/srv/Name``."""
    services = {}
    for name, model in _REGISTRY.items():
        if name.endswith("_Request") and "/srv/" in name:
            base = name.removesuffix("_Request")
            response = _REGISTRY.get(base + "_Response")
            if response is not None:
                services[base] = ServiceType(base, model, response)
    return services


def lookup_service(name: str) -> ServiceType:
    """Service type for ``pkg/srv/Name`` (or ``pkg/Name``)."""
    services = registered_services()
    parts = name.split("/")
    key = f"{parts[0]}/srv/{parts[1]}" if len(parts) == 2 else name
    if key in services:
        return services[key]
    raise InvalidInput("type", name, "unknown service type (`pfield interface list` lists the known ones)")
