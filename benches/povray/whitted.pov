// scenes/whitted.toml for POV-Ray 3.7: a mirror sphere, a glass sphere and a red one on a slightly
// reflective floor, a point light and a spot light, max_trace_level 6 (POV counts the camera ray
// as level 1, so 6 means 5 bounces like raylab's max_depth = 5) and adc_bailout 0.001 (raylab's
// default prune_threshold; `Declare=Bailout=0` with raylab's `--set prune_threshold=0` traces
// every ray to the depth limit in both, as benches/peers/run.sh does). POV-Ray is left-handed; `right -x` makes it right-handed like raylab, and
// `angle` is the horizontal field of view for raylab's 40° vertical one.
// Materials: raylab's kd is POV's pigment × diffuse; ks/shininess are phong/phong_size; kr is
// reflection; kt is the pigment's transmit, which also scales POV's diffuse by (1 − transmit), so
// the glass's diffuse 0.2 gives raylab's kd 0.02. The spot: raylab's max(0, D·L)^2 inside a 28°
// cone is POV's tightness 2 with radius ≈ falloff = 28°.
// Render: povray +Iwhitted.pov +W800 +H600 -A +O/tmp/whitted-pov.png -D +WT2
#ifndef (Bailout) #declare Bailout = 0.001; #end
global_settings { max_trace_level 6 adc_bailout Bailout assumed_gamma 1.0 ambient_light 0 }
background { rgb <0.12, 0.15, 0.22> }
camera { perspective location <0, 1.7, 7.5> look_at <0, 0.8, 0> right -x*4/3 up y sky y angle 2*degrees(atan(tan(radians(20))*4/3)) }
light_source { <-4, 6, 5> rgb 0.7 }
light_source { <3, 5, 3> rgb 0.8 spotlight point_at <3, 5, 3> + <-0.35, -0.75, -0.35> radius 27.99 falloff 28 tightness 2 }
plane { y, 0 texture { pigment { rgb <0.50, 0.45, 0.38> } finish { diffuse 1 phong 0.1 phong_size 20 reflection 0.2 ambient 0 } } }
sphere { <-1.15, 1.0, -1.0>, 1.0 texture { pigment { rgb 1 } finish { diffuse 0.05 phong 0.6 phong_size 200 reflection <0.85, 0.85, 0.9> ambient 0 } } }
sphere { <1.05, 0.75, 0.8>, 0.75
  texture { pigment { rgbt <1, 1, 1, 0.9> } finish { diffuse 0.2 phong 0.7 phong_size 300 reflection 0.08 ambient 0 } }
  interior { ior 1.5 } }
sphere { <0.25, 0.45, -2.9>, 0.45 texture { pigment { rgb <0.75, 0.12, 0.08> } finish { diffuse 1 phong 0.4 phong_size 60 ambient 0 } } }
