"""The base of every model read from a user's file, and the number types they share."""

from typing import Annotated, ClassVar

from pydantic import BaseModel, BeforeValidator, ConfigDict, Field, model_validator

__all__ = ['Number', 'PositiveFloat', 'Vec3', 'StrictModel', 'OneOf', 'not_a_boolean']


def not_a_boolean(value):
    """A validator that refuses a boolean where a number belongs."""
    if isinstance(value, bool):
        raise ValueError('must be a number, not a boolean')
    return value


# YAML reads `true` as a boolean, which pydantic would take as 1.0: a number must be a number
Number = Annotated[float, BeforeValidator(not_a_boolean)]
PositiveFloat = Annotated[Number, Field(gt=0.0)]
Vec3 = tuple[Number, Number, Number]


class StrictModel(BaseModel):
    """Base of every model read from a user's file (scenes, a URDF scene's overrides, sweep
    specs): an unknown key, NaN or Inf is an error; a validated model is frozen."""

    model_config = ConfigDict(extra='forbid', allow_inf_nan=False, frozen=True)



class OneOf(StrictModel):
    """A model that gives exactly one of its optional fields ``KINDS`` (a geometry: box,
    sphere, ...); ``kind`` names it."""

    KINDS: ClassVar[tuple[str, ...]] = ()

    @model_validator(mode='after')
    def _exactly_one(self):
        self._given()
        return self

    def _given(self) -> str:
        given = [k for k in self.KINDS if getattr(self, k) is not None]
        if len(given) != 1:
            raise ValueError(f'give exactly one of {", ".join(self.KINDS)} (got '
                             f'{given or "none"})')
        return given[0]

    @property
    def kind(self) -> str:
        """The name of the field given."""
        return self._given()
