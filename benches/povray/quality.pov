// scenes/quality.toml for POV-Ray 3.7, without its depth of field (render raylab's with
// `--aperture 0`): soft shadows from a rectangular area light and a ball light, a glossy floor and
// a frosted-glass sphere. max_trace_level 5 is raylab's max_depth = 4 (POV counts the camera ray).
//
// Where POV-Ray differs:
// - Area lights are POV-Ray's `area_light` grids (5 × 5, adaptive, jittered) where raylab samples
//   16 stratified points; the ball light is a disc facing the shaded point (`circular orient`),
//   which is what a sphere looks like from there.
// - Glossy reflection and blurry refraction come from micro-normals (`bumps` far below a pixel),
//   so each camera ray takes one perturbed direction and anti-aliasing averages them; raylab
//   traces `glossy_rays` jittered rays per hit. The blur is matched by eye.
// - raylab's attenuation 1 / (1 + 0.02 d²) is POV-Ray's fade_power 2 with fade_distance
//   √50, which doubles the light at the source: the colour is halved.
// - raylab adds ambient light unfiltered (ka = 1); here each finish's ambient is 0.08 divided by
//   its pigment, per channel.
// Render: povray +Iquality.pov +W640 +H400 +A0.3 +AM2 +R3 +O/tmp/quality-pov.png -D +WT2
#version 3.7;
global_settings { max_trace_level 5 assumed_gamma 1.0 ambient_light 1 }
background { rgb <0.04, 0.05, 0.07> }
camera { perspective location <0, 1.6, 7.5> look_at <0, 0.8, 0> right -x*1.6 up y sky y angle 2*degrees(atan(tan(radians(19))*1.6)) }

light_source {
  <-2.5, 5.0, 3.0> rgb <0.45, 0.44, 0.425>
  area_light <2.0, 0, 0>, <0, 0, 1.5>, 5, 5 adaptive 1 jitter
  fade_distance sqrt(50) fade_power 2
}
light_source {
  <3.5, 3.5, -1.0> rgb <0.45, 0.45, 0.5>
  area_light <0.8, 0, 0>, <0, 0, 0.8>, 5, 5 adaptive 1 jitter circular orient
}

#macro Finish(Kd, Ks, Shine, Kr)
  finish { ambient rgb 0.08 / Kd diffuse 1 phong Ks phong_size Shine reflection Kr }
#end

plane { y, 0
  texture {
    pigment { rgb <0.42, 0.42, 0.45> }
    normal { bumps 0.12 scale 0.0005 }
    Finish(<0.42, 0.42, 0.45>, 0.2, 30, 0.25)
  }
}
polygon { 5, <-10, 0, -6>, <10, 0, -6>, <10, 8, -6>, <-10, 8, -6>, <-10, 0, -6>
  texture { pigment { rgb <0.5, 0.48, 0.45> } Finish(<0.5, 0.48, 0.45>, 0, 1, 0) }
}
sphere { <-1.6, 0.6, 2.2>, 0.6
  texture { pigment { rgb <0.12, 0.25, 0.8> } Finish(<0.12, 0.25, 0.8>, 0.4, 60, 0) }
}
sphere { <0.2, 0.8, 0.2>, 0.8
  texture { pigment { rgb <0.8, 0.12, 0.1> } Finish(<0.8, 0.12, 0.1>, 0.5, 80, 0) }
}
sphere { <1.9, 0.7, 1.2>, 0.7
  texture {
    pigment { rgbt <0.02, 0.02, 0.02, 0.9> }
    normal { bumps 0.09 scale 0.0005 }
    Finish(<0.02, 0.02, 0.02>, 0.5, 200, 0.05)
  }
  interior { ior 1.45 }
}
cylinder { <-2.2, 0, -3.0>, <-2.2, 3.0, -3.0>, 0.45
  texture { pigment { rgb <0.85, 0.8, 0.55> } Finish(<0.85, 0.8, 0.55>, 0.2, 20, 0) }
}
