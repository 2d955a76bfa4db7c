"""Protocol messages filled from plain Python: dicts of field names, enums by short name, colours as a number or
(r, g, b), digests, vectors and Brdfs in their plain forms. Errors name the field's path ("job.material.ggx.alpha")."""

from google.protobuf import descriptor as _descriptor

from . import kiln_pb2 as pb
from .digests import _as_digest


def _enum_value(enum_type, value, path):
    if isinstance(value, bool):
        raise TypeError("%s: expected a %s name or number, got %r" % (path, enum_type.name, value))
    if isinstance(value, int):
        if value not in enum_type.values_by_number:
            raise ValueError("%s: %d is not a %s value" % (path, value, enum_type.name))
        return value
    if isinstance(value, str):
        name = value.strip().upper().replace("-", "_")
        # Fresnel -> FRESNEL_SCHLICK, Masking -> MASKING_V_GROOVE, EnvironmentLobe -> ENVIRONMENT_LOBE_GGX
        prefix = "".join("_" + c if c.isupper() and i else c for i, c in enumerate(enum_type.name)).upper() + "_"
        for candidate in (name, prefix + name):
            if candidate in enum_type.values_by_name:
                return enum_type.values_by_name[candidate].number
        choices = ", ".join(v.name[len(prefix):].lower() if v.name.startswith(prefix) else v.name
                            for v in enum_type.values)
        raise ValueError("%s: %r is not a %s (one of: %s)" % (path, value, enum_type.name, choices))
    raise TypeError("%s: expected a %s name or number, got %r" % (path, enum_type.name, value))


def _set_color(color, value, path):
    if isinstance(value, pb.Color):
        color.CopyFrom(value)
    elif isinstance(value, (int, float)) and not isinstance(value, bool):
        color.r = color.g = color.b = float(value)
    elif isinstance(value, dict):
        _fill(color, value, path)
    elif isinstance(value, (tuple, list)) and len(value) == 3:
        color.r, color.g, color.b = (float(v) for v in value)
    else:
        raise TypeError("%s: expected a number (grey), (r, g, b) or a kiln.pb.Color, got %r" % (path, value))


def _set_model(message, model, params, path):
    oneof = message.DESCRIPTOR.oneofs_by_name["model"]
    names = [f.name for f in oneof.fields]
    if model not in names:
        raise ValueError("%s: unknown model %r (one of: %s)" % (path, model, ", ".join(names)))
    sub = getattr(message, model)
    sub.SetInParent()
    _fill(sub, params, path + "." + model)


def _set_message(target, value, path):
    """A message field from a kiln.pb message of its type, or the plain Python forms of the common ones."""
    full_name = target.DESCRIPTOR.full_name
    if isinstance(value, type(target)):
        target.CopyFrom(value)
    elif full_name == "kiln.v1.Color":
        _set_color(target, value, path)
    elif full_name == "kiln.v1.Digest":
        try:
            target.CopyFrom(_as_digest(value))
        except TypeError as e:
            raise TypeError("%s: %s" % (path, e)) from None
    elif full_name == "kiln.v1.Vector3" and isinstance(value, (tuple, list)):
        if len(value) != 3:
            raise TypeError("%s: expected (x, y, z), got %r" % (path, value))
        target.x, target.y, target.z = (float(v) for v in value)
    elif full_name == "kiln.v1.Brdf":
        if not isinstance(value, dict) or "model" not in value:
            raise TypeError("%s: expected a dict with a 'model' key, e.g. {'model': 'lambert', "
                            "'albedo': 0.5}, got %r" % (path, value))
        rest = dict(value)
        _set_model(target, rest.pop("model"), rest, path)
    elif isinstance(value, dict):
        target.SetInParent()
        _fill(target, value, path)
    else:
        raise TypeError("%s: expected a dict or a kiln.pb.%s, got %r" % (path, target.DESCRIPTOR.name, value))


def _scalar(field, value, path):
    if field.type == _descriptor.FieldDescriptor.TYPE_ENUM:
        return _enum_value(field.enum_type, value, path)
    if field.type in (_descriptor.FieldDescriptor.TYPE_DOUBLE, _descriptor.FieldDescriptor.TYPE_FLOAT):
        try:
            return float(value)
        except (TypeError, ValueError):
            raise TypeError("%s: expected a number, got %r" % (path, value)) from None
    return value


def _fill(message, values, path):
    """Sets `message`'s fields from a dict of field names: scalars, enums by name, messages from dicts (or their
    plain forms: colors, digests, vectors, Brdfs), repeated fields from lists. TypeError/ValueError name the path."""
    fields = message.DESCRIPTOR.fields_by_name
    given = {}
    for key, value in values.items():
        if value is None:
            continue  # unset: the server's default
        field = fields.get(key)
        here = path + "." + key
        if field is None:
            raise TypeError("%s: %s has no field %r (fields: %s)"
                            % (path, message.DESCRIPTOR.name, key, ", ".join(fields)))
        if field.containing_oneof is not None:
            oneof = field.containing_oneof.name
            if oneof in given:
                raise ValueError("%s: give one of %s, not both %s and %s"
                                 % (path, ", ".join(f.name for f in field.containing_oneof.fields), given[oneof], key))
            given[oneof] = key
        if field.label == _descriptor.FieldDescriptor.LABEL_REPEATED:
            if isinstance(value, (str, bytes, dict)) or not hasattr(value, "__iter__"):
                raise TypeError("%s: expected a list, got %r" % (here, value))
            target = getattr(message, key)
            del target[:]
            for i, item in enumerate(value):
                item_path = "%s[%d]" % (here, i)
                if field.type == _descriptor.FieldDescriptor.TYPE_MESSAGE:
                    _set_message(target.add(), item, item_path)
                else:
                    target.append(_scalar(field, item, item_path))
        elif field.type == _descriptor.FieldDescriptor.TYPE_MESSAGE:
            _set_message(getattr(message, key), value, here)
        else:
            setattr(message, key, _scalar(field, value, here))
