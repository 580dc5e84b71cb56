"""Parameter records serialise themselves: nested records and tuples back from the field types, off fields left out."""

import json

from deformsim.sampling import CameraParams, LightParams, MaterialParams, SampleParams, SurfaceParams


def _sample(**kw) -> SampleParams:
    cams = (CameraParams(10.0, 60.0, 0.4), CameraParams(100.0, 55.0, 0.35, fill=0.5, cut_side="none"))
    return SampleParams(index=1, seed=2, label="deformed", families=("dent",), keys={"k": 0.5}, displacement={},
                        seal=0.3, tab=0.1, hdri="city", hdri_rotation=5.0, hdri_strength=1.0, cameras=cams, **kw)


def test_off_framing_fields_are_left_out_of_a_camera_record():
    assert CameraParams(1.0, 2.0, 3.0).to_dict() == {"azimuth": 1.0, "polar": 2.0, "radius": 3.0}
    assert CameraParams(1.0, 2.0, 3.0, fstop=4.0).to_dict() == {"azimuth": 1.0, "polar": 2.0, "radius": 3.0, "fstop": 4.0}


def test_nested_records_and_tuples_come_back_from_json():
    p = _sample(material=MaterialParams(color=(0.1, 0.2, 0.3), roughness=0.5), drop_rotation=(1.0, 0.0, 0.0, 0.0),
                lights=(LightParams("ring", 1, 2, 3, 4, 5, 6, 7, 8),),
                surface=SurfaceParams("wood", 0.1, 0.2, 0.3, 0.4, 1.0, 90.0, (0.5, 0.6)))
    back = SampleParams.from_dict(json.loads(json.dumps(p.to_dict())))
    assert back == p and isinstance(back.material.color, tuple) and isinstance(back.surface.offset, tuple)
    assert p.to_dict()["drop_rotation"] == (1.0, 0.0, 0.0, 0.0) and p.to_dict()["design"] is None


def test_fields_left_out_of_a_record_load_as_their_defaults():
    d = _sample().to_dict()
    for k in ("lights", "surface", "drop_rotation", "bank"):
        del d[k]
    assert SampleParams.from_dict(d) == _sample()
