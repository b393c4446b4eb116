// A steel cantilever for the gmsh -> CalculiX -> ecmor pipeline (run.sh): length L along x,
// section b (y) x h (z), meshed with structured 20-node hexahedra (C3D20 in the .inp).
// Physical groups become node sets of the deck (gmsh -setnumber Mesh.SaveGroupsOfNodes 1):
// CLAMP (the face x = 0, fixed by clamp.inp), TIP (the face x = L, inputs and outputs), BEAM
// (the volume: its element set carries the material).
L = 1.0;  b = 0.03;  h = 0.05;
elements_along = 10;  elements_y = 1;  elements_z = 2;

Point(1) = {0, 0, 0};  Point(2) = {0, b, 0};  Point(3) = {0, b, h};  Point(4) = {0, 0, h};
Line(1) = {1, 2};  Line(2) = {2, 3};  Line(3) = {3, 4};  Line(4) = {4, 1};
Curve Loop(1) = {1, 2, 3, 4};
Plane Surface(1) = {1};
Transfinite Curve{1, 3} = elements_y + 1;
Transfinite Curve{2, 4} = elements_z + 1;
Transfinite Surface{1};
Recombine Surface{1};
out[] = Extrude {L, 0, 0} { Surface{1}; Layers{elements_along}; Recombine; };

Physical Surface("CLAMP") = {1};
Physical Surface("TIP") = {out[0]};
Physical Volume("BEAM") = {out[1]};
