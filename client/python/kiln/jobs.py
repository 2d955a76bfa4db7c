"""Job specs: kiln.pb.JobSpec from a job file's text or from keyword arguments (material and environment jobs; lightmap
jobs are in lightmap.py), and the names of job states."""

from google.protobuf import text_format

from . import kiln_pb2 as pb
from .digests import _as_digest
from .fields import _fill, _set_color, _set_model


def state_name(state):
    """"SUCCEEDED" for kiln.pb.JOB_STATE_SUCCEEDED, and so on."""
    try:
        return pb.JobState.Name(state).replace("JOB_STATE_", "")
    except ValueError:
        return "STATE_%d" % state


def parse_job(text):
    """A kiln.pb.JobSpec from protobuf text format (the job files of `kiln submit`). ValueError if malformed."""
    try:
        return text_format.Parse(text, pb.JobSpec())
    except text_format.ParseError as e:
        raise ValueError("job spec: %s" % e) from e


def load_job(path):
    """A kiln.pb.JobSpec from a text-format job file. ValueError names the file and the line if malformed."""
    with open(path, "r", encoding="utf-8") as f:
        text = f.read()
    try:
        return text_format.Parse(text, pb.JobSpec())
    except text_format.ParseError as e:
        raise ValueError("%s: %s" % (path, e)) from e


def material_job(model, *, name="", table_mu=None, table_roughness=None, merl=None, preview=None, samples=None,
                 target_error=None, time_limit_seconds=None, seed=None, force_effects=None, **params):
    """A kiln.pb.JobSpec for a material bake, from keyword arguments.

    `model` is a MaterialJob model ("lambert", "oren_nayar", "oren_nayar_simple", "cook_torrance", "ggx",
    "beckmann", "schlick", "schlick_double", "layered"); the other keywords not named here are that model's fields
    (kiln.proto): alpha, alpha_x, alpha_y, eta, fresnel, distribution, masking, normalization, f0, albedo, sigma,
    interreflection, c, r, p, top, bottom, diffuse, specular, combine, specular_weight. Colors take a number (grey),
    (r, g, b) or a kiln.pb.Color; enums a short name ("schlick", "height_correlated"), the full name or the number;
    nested messages a dict (a Brdf as {"model": "lambert", "albedo": 0.5}). None leaves a field to its default.

        material_job("ggx", alpha=0.3, fresnel="schlick", f0=0.04, table_mu=32, samples=4096)
        material_job("layered", diffuse={"model": "lambert", "albedo": (0.8, 0.2, 0.1)},
                     specular={"model": "ggx", "alpha": 0.2, "fresnel": "exact", "eta": 1.5})
    """
    spec = pb.JobSpec(name=name)
    _set_model(spec.material, model, params, "job.material")
    _fill(spec.material, {"table_mu": table_mu, "table_roughness": table_roughness, "merl": merl, "preview": preview},
          "job.material")
    _set_quality_and_effects(spec, {"samples": samples, "target_error": target_error,
                                    "time_limit_seconds": time_limit_seconds, "seed": seed}, force_effects)
    return spec


def _set_quality_and_effects(spec, quality, force_effects):
    if any(v is not None for v in quality.values()):
        spec.quality.SetInParent()
        _fill(spec.quality, quality, "job.quality")
    for effect, enabled in (force_effects or {}).items():
        spec.force_effects[effect] = bool(enabled)


def environment_job(image=None, *, faces=None, constant=None, name="", samples=None, target_error=None, seed=None,
                    force_effects=None, **settings):
    """A kiln.pb.JobSpec for an environment bake (image-based lighting), from keyword arguments.

    The environment is exactly one of: `image`, the Digest of an uploaded equirectangular image (what
    Client.upload_file returns, a kiln.pb.Digest or (sha256, size)); `faces`, six such digests in the order
    +X, -X, +Y, -Y, +Z, -Z; `constant`, a radiance (a number, (r, g, b) or a kiln.pb.Color). The other keywords are
    EnvironmentJob's fields (kiln.proto): color_space, rotation_degrees, intensity, lobe ("ggx", "beckmann",
    "cook_torrance", "schlick"), size, levels, irradiance_size, dfg_size, dfg_samples, dfg_masking ("separable",
    "height_correlated"; default height-correlated), preview. samples, target_error and seed go into the job's
    quality. None leaves a field to its default.

        with kiln.Client(...) as c:
            job = kiln.environment_job(c.upload_file("sky.exr"), size=128, lobe="ggx")
            c.run(job, out_dir="out/sky_env")
    """
    given = [k for k, v in (("image", image), ("faces", faces), ("constant", constant)) if v is not None]
    if len(given) != 1:
        raise ValueError("job.environment: give exactly one of image, faces or constant, got %s"
                         % (", ".join(given) or "none"))
    spec = pb.JobSpec(name=name)
    env = spec.environment
    if image is not None:
        env.image.CopyFrom(_as_digest(image))
    elif faces is not None:
        faces = list(faces)
        if len(faces) != 6:
            raise ValueError("job.environment.faces: exactly six faces (+X, -X, +Y, -Y, +Z, -Z), got %d" % len(faces))
        for face in faces:
            env.faces.digests.add().CopyFrom(_as_digest(face))
    else:
        _set_color(env.constant, constant, "job.environment.constant")
    _fill(env, settings, "job.environment")
    _set_quality_and_effects(spec, {"samples": samples, "target_error": target_error, "seed": seed}, force_effects)
    return spec
