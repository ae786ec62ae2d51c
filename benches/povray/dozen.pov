// scenes/dozen.toml for POV-Ray 3.7: a dozen analytic objects, two point lights, max_trace_level 6
// (POV counts the camera ray as level 1, so 6 means 5 bounces like raylab's max_depth = 5).
// POV-Ray is left-handed; `right -x` makes it right-handed like raylab, and `angle` is the
// horizontal field of view for raylab's 45° vertical one.
// `Declare=Bailout=0` (with raylab's `--set prune_threshold=0`) traces every ray to the depth limit
// in both, as benches/peers/run.sh does; the default is POV-Ray's own 1/255.
// Render: povray +Idozen.pov +W800 +H600 -A +O/tmp/dozen-pov.png -D +WT2
#ifndef (Bailout) #declare Bailout = 1/255; #end
global_settings { max_trace_level 6 adc_bailout Bailout assumed_gamma 1.0 ambient_light 0 }
background { rgb <0.1, 0.12, 0.16> }
camera { perspective location <0, 3.5, 9> look_at <0, 0.8, 0> right -x*4/3 up y sky y angle 2*degrees(atan(tan(radians(22.5))*4/3)) }
light_source { <5, 8, 6> rgb 0.8 }
light_source { <-6, 6, 3> rgb 0.5 }
#declare Floor = texture { pigment { rgb 0.5 } finish { diffuse 1 reflection 0.3 ambient 0 } }
#declare Mirror = texture { pigment { rgb 1 } finish { diffuse 0.1 phong 0.5 phong_size 100 reflection 0.7 ambient 0 } }
#declare Red = texture { pigment { rgb <0.8, 0.15, 0.1> } finish { diffuse 1 phong 0.5 phong_size 50 ambient 0 } }
#declare Blue = texture { pigment { rgb <0.1, 0.2, 0.8> } finish { diffuse 1 phong 0.5 phong_size 50 ambient 0 } }
plane { y, 0 texture { Floor } }
sphere { <-2.5, 0.7, -2>, 0.7 texture { Mirror } }
sphere { <0, 0.7, -2>, 0.7 texture { Red } }
sphere { <2.5, 0.7, -2>, 0.7 texture { Mirror } }
sphere { <-2.5, 0.7, 0>, 0.7 texture { Blue } }
sphere { <0, 0.7, 0>, 0.7 texture { Mirror } }
sphere { <2.5, 0.7, 0>, 0.7 texture { Red } }
sphere { <-2.5, 0.7, 2>, 0.7 texture { Mirror } }
sphere { <0, 0.7, 2>, 0.7 texture { Blue } }
sphere { <2.5, 0.7, 2>, 0.7 texture { Mirror } }
cylinder { <-4.5, 0, -3>, <-4.5, 2.5, -3>, 0.5 texture { Red } }
triangle { <3.5, 0, -4>, <5.5, 0, -4>, <4.5, 3, -4> texture { Blue } }
