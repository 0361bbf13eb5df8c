"""The shader-input contract: every GPU resource a shading pass reads, as one object.

A shading pass (lighting, blend, the debug views, the bench's floor, limit and forward
renderer) compiles its programs with the defines of what it reads and, at each draw,
binds those textures and sets their uniforms. Each such resource is a ``ShaderInput``:

* ``role``: the name a pass asks for it by ("lights", "materials", "environment", ...);
  a context holds at most one input per role;
* ``defines()``: the #defines it compiles into a program (``SHADOWS``, ``TILE_QUADS``,
  ``ENVIRONMENT_IBL``, ...), empty where the GLSL needs none;
* ``samplers()``: (sampler uniform, texture) pairs it binds;
* ``uniforms(program)``: its other uniforms, set on each program before a draw;
* ``bind(program, units)``: the program's samplers pointed at the units the context
  bound the textures to, then ``uniforms(program)`` (the base class's does both).

A ``ShadingContext`` holds the inputs of a frame. Its ``defines()`` is the union of its
inputs' (two inputs may not give one name two values), ``use()`` binds every texture to a
unit of its own, once per pass run, and ``bind(program)`` binds every input for one
program. A pass that reads only some inputs takes ``only(...)`` of them, and one with
inputs of its own (the bench's pixel masks) adds them with ``with_inputs(...)``; a pass
asks for the roles it cannot shade without with ``require``, which names what is
missing. The Renderer builds the frame's context (``shading_context``) once per lighting
build, from the G-buffer, the lights, the material table and what the renderer already
owns: the environment's light (app/render/ibl.py), the shadow maps
(app/render/shadows.py ``ShadowPass``) and the tile culler (app/render/culling.py
``LightCuller``), which implement the contract themselves. docs/architecture.md,
"Adding a shading input", is the checklist for a new one.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping

import moderngl
import numpy as np

from app.common.camera import CameraFrame
from app.common.lights import (
    LightType,
    PunctualLight,
    has_area_lights,
    pack_area_shapes,
    pack_lights,
)
from app.frame.camera import gl_bytes
from app.frame.materials import MaterialTable
from app.gl.fullscreen import Texture
from app.render.gbuffer import GBuffer
from app.render.tables import material_texture, ms_texture, sheen_texture

# The roles of the inputs a frame has, in the order a context binds them.
GBUFFER, LIGHTS, MATERIALS, MS_TABLE, SHEEN_TABLE = (
    "gbuffer", "lights", "materials", "ms_table", "sheen_table",
)  # fmt: skip
TILES, ENVIRONMENT, SHADOWS = "tiles", "environment", "shadows"
AREA_LIGHTS = "area_lights"
# What a pass that decodes the G-buffer and evaluates the BRDF of the table's materials
# reads (the debug views, the bench's floor).
SURFACE_ROLES = (GBUFFER, LIGHTS, MATERIALS, MS_TABLE, SHEEN_TABLE, AREA_LIGHTS)


class MissingInputError(ValueError):
    """A pass was given a context without an input it cannot shade without."""


class ShaderInput:
    """One GPU resource a shading pass reads: its defines, textures and uniforms (the
    module docstring). Subclasses set ``role`` and override what they have."""

    role: str = ""

    def defines(self) -> dict[str, int]:
        """The #defines a program reading this input is compiled with."""
        return {}

    def samplers(self) -> list[tuple[str, Texture]]:
        """(sampler uniform, texture) pairs this input binds."""
        return []

    def uniforms(self, program: moderngl.Program) -> None:
        """Set this input's uniforms other than samplers on ``program``."""

    def bind(self, program: moderngl.Program, units: Mapping[str, int]) -> None:
        """Point ``program``'s samplers of this input at ``units`` (sampler -> unit, where
        a context bound the textures: ``ShadingContext.use``), those the program has (a
        permutation may not read every texture), then set its uniforms."""
        for name, _ in self.samplers():
            if name in program:
                program[name].value = units[name]
        self.uniforms(program)

    def release(self) -> None:
        """Release the GPU objects this input made (a context releases those it owns)."""


class GBufferInput(ShaderInput):
    """The G-buffer's targets as a pass that decodes them reads them
    (gbuffer/decode.glsl): ``GBuffer.defines()`` (encoding, layout, optional targets) and
    ``GBuffer.samplers()``. An adapter: the G-buffer is the renderer's."""

    role = GBUFFER

    def __init__(self, gbuffer: GBuffer) -> None:
        self.gbuffer = gbuffer

    def defines(self) -> dict[str, int]:
        return dict(self.gbuffer.defines())

    def samplers(self) -> list[tuple[str, Texture]]:
        return list(self.gbuffer.samplers())


class LightInput(ShaderInput):
    """The frame's lights (app/common/lights.py ``pack_lights``: 3 texels per light, one
    light per row) in the RGBA32F texture ``u_lights`` every shading pass can read, and
    ``u_light_count``. ``form`` "uniform" (the lighting pass's, app/render/lighting.py
    ``light_form``) reads the same texels from the uniform array ``u_light_vec`` of
    ``slots`` lights instead (``LIGHT_UNIFORMS``): ``in_form`` gives that view of the
    same texture."""

    role = LIGHTS

    def __init__(self, ctx: moderngl.Context, lights: list[PunctualLight]) -> None:
        packed = pack_lights(lights)
        self.texels = packed.tobytes()
        self.rows = packed.shape[0]
        self.texture = ctx.texture((3, self.rows), 4, self.texels, dtype="f4")
        self.texture.filter = (moderngl.NEAREST, moderngl.NEAREST)
        self.count = len(lights)
        # whether the cone is compiled in (SPOT_LIGHTS, glsl/lights/punctual.glsl)
        self.spots = any(light.type == LightType.SPOT for light in lights)
        self.form = "texture"
        self.slots = 0
        self.array = b""  # u_light_vec's bytes, "uniform" only
        self._owner = True

    def in_form(self, form: str, slots: int) -> LightInput:
        """This input read in ``form`` ("texture" or "uniform", an array of ``slots``
        lights); the texture is this input's (released with it, not with the view)."""
        view = object.__new__(LightInput)
        view.__dict__.update(self.__dict__)
        view.form, view.slots, view._owner = form, slots, False
        # The texture's texels, padded with zeros to the array's size (moderngl writes a
        # uniform array only whole).
        pad = bytes(48 * max(slots - self.rows, 0))
        view.array = self.texels + pad if form == "uniform" else b""
        return view

    def defines(self) -> dict[str, int]:
        form = {"LIGHT_UNIFORMS": self.slots} if self.form == "uniform" else {}
        return {"SPOT_LIGHTS": int(self.spots), **form}

    def samplers(self) -> list[tuple[str, Texture]]:
        return [("u_lights", self.texture)]

    def uniforms(self, program: moderngl.Program) -> None:
        if "u_light_vec" in program:  # LIGHT_UNIFORMS; the program may be another scene's
            program["u_light_vec"].write(self.array)
        if "u_light_count" in program:  # the tiled loop counts through its masks instead
            program["u_light_count"].value = self.count

    def release(self) -> None:
        if self._owner:
            self.texture.release()


class MaterialInput(ShaderInput):
    """The material table (app/frame/materials.py) as the RGBA32F texture ``u_materials``
    (app/render/tables.py ``material_texture``); ``table`` is kept for the passes that
    compile one program per model group."""

    role = MATERIALS

    def __init__(self, ctx: moderngl.Context, table: MaterialTable) -> None:
        self.table = table
        self.texture = material_texture(ctx, table)

    def samplers(self) -> list[tuple[str, Texture]]:
        return [("u_materials", self.texture)]

    def release(self) -> None:
        self.texture.release()


class LookupTable(ShaderInput):
    """A lookup table a BRDF reads by hand with texelFetch (app/render/tables.py): the
    Kulla-Conty multiple-scattering table ``u_ms_table`` or the sheen albedo table
    ``u_sheen_table``. No defines: the models that read them compile them in."""

    def __init__(self, role: str, sampler: str, texture: moderngl.Texture) -> None:
        self.role = role
        self.sampler = sampler
        self.texture = texture

    def samplers(self) -> list[tuple[str, Texture]]:
        return [(self.sampler, self.texture)]

    def release(self) -> None:
        self.texture.release()


class AreaLightInput(ShaderInput):
    """The area lights' inputs (glsl/lights/area.glsl; docs/area_lights.md): the LTC table
    ``u_ltc_table`` (app/reference/area_lights.py ``ltc_table``: M^-1's four entries, then
    n_D and f_b, side by side, RGBA32F) and ``u_area_shapes`` (each light's axis_v,
    ``pack_area_shapes``). ``AREA_LIGHTS`` and ``LTC_SIZE`` compile the area term in; a
    frame without an area light has no such input, so its programs are as before."""

    role = AREA_LIGHTS

    def __init__(self, ctx: moderngl.Context, lights: list[PunctualLight]) -> None:
        from app.reference.area_lights import ltc_table  # area-light frames only

        table = ltc_table()
        self.size = table.shape[0]
        texels = np.zeros((self.size, 2 * self.size, 4), np.float32)  # rows: roughness
        texels[:, : self.size] = table[..., :4]
        texels[:, self.size :, :2] = table[..., 4:6]
        self.table = ctx.texture((2 * self.size, self.size), 4, texels.tobytes(), dtype="f4")
        shapes = pack_area_shapes(lights)
        self.shapes = ctx.texture((len(shapes), 1), 4, shapes.tobytes(), dtype="f4")
        for tex in (self.table, self.shapes):
            tex.filter = (moderngl.NEAREST, moderngl.NEAREST)

    def defines(self) -> dict[str, int]:
        return {"AREA_LIGHTS": 1, "LTC_SIZE": self.size}

    def samplers(self) -> list[tuple[str, Texture]]:
        return [("u_ltc_table", self.table), ("u_area_shapes", self.shapes)]

    def release(self) -> None:
        self.table.release()
        self.shapes.release()


def bind_camera(program: moderngl.Program, camera: CameraFrame) -> None:
    """The camera's uniforms of a pass that rebuilds positions from view depth (those the
    program has): its position, camera-to-world rotation and tan(fov_y / 2)."""
    if "u_camera_pos" in program:
        program["u_camera_pos"].value = tuple(float(x) for x in camera.position)
    if "u_camera_to_world" in program:
        program["u_camera_to_world"].write(gl_bytes(camera.camera_to_world))
    if "u_tan_half_fov" in program:
        program["u_tan_half_fov"].value = camera.tan_half_fov


class ShadingContext:
    """The shader inputs of a frame (or of one pass): at most one per role, bound in the
    order given. ``owned``: the inputs this context made and releases (``release``); the
    others (G-buffer, environment, shadows, culler) belong to the renderer."""

    def __init__(self, inputs: Iterable[ShaderInput], owned: Iterable[ShaderInput] = ()) -> None:
        self._inputs: dict[str, ShaderInput] = {}
        for item in inputs:
            if not item.role:
                raise ValueError(f"{type(item).__name__} has no role")
            if item.role in self._inputs:
                raise ValueError(f"two shader inputs of role {item.role!r}")
            self._inputs[item.role] = item
        samplers = [name for item in self._inputs.values() for name, _ in item.samplers()]
        if len(set(samplers)) != len(samplers):
            raise ValueError(f"two shader inputs bind one sampler: {sorted(samplers)}")
        self._owned = list(owned)
        self._units: dict[str, int] | None = None

    @property
    def roles(self) -> tuple[str, ...]:
        return tuple(self._inputs)

    def __contains__(self, role: str) -> bool:
        return role in self._inputs

    def get(self, role: str) -> ShaderInput | None:
        """The input of ``role``, None where the frame has none (no environment, ...)."""
        return self._inputs.get(role)

    def __getitem__(self, role: str) -> ShaderInput:
        if role not in self._inputs:
            raise MissingInputError(f"no shader input {role!r} (the context has {self.roles})")
        return self._inputs[role]

    def require(self, user: str, *roles: str) -> None:
        """MissingInputError naming ``user`` and every role of ``roles`` this context lacks:
        a pass checks what it cannot shade without before it compiles anything."""
        missing = [role for role in roles if role not in self._inputs]
        if missing:
            raise MissingInputError(
                f"{user} needs the shader inputs {missing}; the context has {list(self.roles)}"
            )

    def only(self, *roles: str) -> ShadingContext:
        """A context of this one's inputs of ``roles`` (those it has), owning none."""
        return ShadingContext(item for role, item in self._inputs.items() if role in roles)

    def with_inputs(self, *inputs: ShaderInput) -> ShadingContext:
        """A context of this one's inputs with ``inputs`` added, or in place of this one's
        of the same role; it owns none of them."""
        replaced = {item.role: item for item in inputs}
        kept = [replaced.pop(role, item) for role, item in self._inputs.items()]
        return ShadingContext([*kept, *replaced.values()])

    def defines(self) -> dict[str, int]:
        """The union of the inputs' defines; ValueError where two give one name two
        values (they would compile a program neither expects)."""
        out: dict[str, int] = {}
        origin: dict[str, str] = {}
        for role, item in self._inputs.items():
            for name, value in item.defines().items():
                if name in out and out[name] != value:
                    raise ValueError(
                        f"shader inputs {origin[name]!r} and {role!r} define {name} as "
                        f"{out[name]} and {value}"
                    )
                out[name], origin[name] = value, role
        return out

    def samplers(self) -> list[tuple[str, Texture]]:
        return [pair for item in self._inputs.values() for pair in item.samplers()]

    def use(self, first_unit: int = 0) -> int:
        """Bind every input's textures to units ``first_unit``, ... (once per pass run,
        before ``bind``); returns the next free unit (a mesh pass's maps go there)."""
        self._units = {}
        unit = first_unit
        for name, texture in self.samplers():
            texture.use(unit)
            self._units[name] = unit
            unit += 1
        return unit

    def bind(self, program: moderngl.Program) -> None:
        """Bind every input for ``program``: samplers to the units of the last ``use``,
        then each input's uniforms."""
        if self._units is None:
            raise RuntimeError("ShadingContext.use() binds the textures before bind()")
        for item in self._inputs.values():
            item.bind(program, self._units)

    def release(self) -> None:
        """Release the inputs this context made."""
        for item in self._owned:
            item.release()
        self._owned = []


def shading_context(
    ctx: moderngl.Context,
    lights: list[PunctualLight],
    table: MaterialTable,
    *,
    gbuffer: GBuffer | None = None,
    ms_table: np.ndarray | None = None,
    every_table: bool = False,
    environment: ShaderInput | None = None,
    shadows: ShaderInput | None = None,
    tiles: ShaderInput | None = None,
) -> ShadingContext:
    """A frame's context: ``gbuffer`` (where the passes decode one), the light texture,
    the material table's texture, the lookup tables its models read (every one with
    ``every_table``, the uber program's; ``ms_table``: Kulla-Conty tables (a stack, one
    per G2 form) other than the shipped ones), then the renderer's ``tiles``
    (LightCuller), ``environment`` (EnvironmentLighting or UniformEnvironment) and
    ``shadows`` (ShadowPass) where the frame has them. The context owns (releases) the
    textures it made here."""
    owned: list[ShaderInput] = [LightInput(ctx, lights), MaterialInput(ctx, table)]
    if every_table or any(model.multiscatter for model in table.models):
        owned.append(LookupTable(MS_TABLE, "u_ms_table", ms_texture(ctx, ms_table)))
    if every_table or any(model.sheen != "none" for model in table.models):
        # sheen (RTR4 §9.10): the albedo table, where a model uses it
        owned.append(LookupTable(SHEEN_TABLE, "u_sheen_table", sheen_texture(ctx)))
    if has_area_lights(lights):  # the LTC table and the shapes (docs/area_lights.md)
        owned.append(AreaLightInput(ctx, lights))
    inputs = [GBufferInput(gbuffer)] if gbuffer is not None else []
    inputs += [*owned, *(x for x in (tiles, environment, shadows) if x is not None)]
    return ShadingContext(inputs, owned)
