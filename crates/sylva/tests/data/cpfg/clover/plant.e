executable: clover -e plant.e enviro.spec
communication type: memory
turtle position:P:%g %g %g
