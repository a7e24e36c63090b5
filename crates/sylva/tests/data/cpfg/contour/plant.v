/* test view file for the contour model */
line style: cylinder
contour sides: 4
twist of cylinders: on
contour: 1 flat.con
