set terminal pngcairo size 1440,520 font ',10'
set output 'results/peers/peers.png'
set multiplot layout 1,3
set logscale xy
set grid
set xlabel 'bodies n'
set ylabel 'median ms per frame'
set key top left font ',8'
set title 'max speed 0.05 diameters/frame'
plot 'results/peers/peers.dat' index 0 using 1:2 with lp pt 7 lw 3 title 'vadop', \
     'results/peers/peers.dat' index 1 using 1:2 with lp pt 7 lw 3 title 'vadop-brute', \
     'results/peers/peers.dat' index 2 using 1:2 with lp dt 2 pt 6 lw 3 title 'vadop-discrete', \
     'results/peers/peers.dat' index 3 using 1:2 with lp dt 2 pt 6 lw 1 title 'bullet-dbvt', \
     'results/peers/peers.dat' index 4 using 1:2 with lp dt 2 pt 6 lw 1 title 'bullet-sap', \
     'results/peers/peers.dat' index 5 using 1:2 with lp pt 7 lw 1 title 'bullet-ccd', \
     'results/peers/peers.dat' index 6 using 1:2 with lp dt 2 pt 6 lw 1 title 'fcl-dtree', \
     'results/peers/peers.dat' index 7 using 1:2 with lp dt 2 pt 6 lw 1 title 'fcl-sap', \
     'results/peers/peers.dat' index 8 using 1:2 with lp pt 7 lw 1 title 'fcl-ccd', \
     'results/peers/peers.dat' index 9 using 1:2 with lp dt 2 pt 6 lw 1 title 'rapier', \
     'results/peers/peers.dat' index 10 using 1:2 with lp pt 7 lw 1 title 'parry-ccd'
set title 'max speed 0.5 diameters/frame'
plot 'results/peers/peers.dat' index 11 using 1:2 with lp pt 7 lw 3 title 'vadop', \
     'results/peers/peers.dat' index 12 using 1:2 with lp pt 7 lw 3 title 'vadop-brute', \
     'results/peers/peers.dat' index 13 using 1:2 with lp dt 2 pt 6 lw 3 title 'vadop-discrete', \
     'results/peers/peers.dat' index 14 using 1:2 with lp dt 2 pt 6 lw 1 title 'bullet-dbvt', \
     'results/peers/peers.dat' index 15 using 1:2 with lp dt 2 pt 6 lw 1 title 'bullet-sap', \
     'results/peers/peers.dat' index 16 using 1:2 with lp pt 7 lw 1 title 'bullet-ccd', \
     'results/peers/peers.dat' index 17 using 1:2 with lp dt 2 pt 6 lw 1 title 'fcl-dtree', \
     'results/peers/peers.dat' index 18 using 1:2 with lp dt 2 pt 6 lw 1 title 'fcl-sap', \
     'results/peers/peers.dat' index 19 using 1:2 with lp pt 7 lw 1 title 'fcl-ccd', \
     'results/peers/peers.dat' index 20 using 1:2 with lp dt 2 pt 6 lw 1 title 'rapier', \
     'results/peers/peers.dat' index 21 using 1:2 with lp pt 7 lw 1 title 'parry-ccd'
set title 'max speed 5 diameters/frame'
plot 'results/peers/peers.dat' index 22 using 1:2 with lp pt 7 lw 3 title 'vadop', \
     'results/peers/peers.dat' index 23 using 1:2 with lp pt 7 lw 3 title 'vadop-brute', \
     'results/peers/peers.dat' index 24 using 1:2 with lp dt 2 pt 6 lw 3 title 'vadop-discrete', \
     'results/peers/peers.dat' index 25 using 1:2 with lp dt 2 pt 6 lw 1 title 'bullet-dbvt', \
     'results/peers/peers.dat' index 26 using 1:2 with lp dt 2 pt 6 lw 1 title 'bullet-sap', \
     'results/peers/peers.dat' index 27 using 1:2 with lp pt 7 lw 1 title 'bullet-ccd', \
     'results/peers/peers.dat' index 28 using 1:2 with lp dt 2 pt 6 lw 1 title 'fcl-dtree', \
     'results/peers/peers.dat' index 29 using 1:2 with lp dt 2 pt 6 lw 1 title 'fcl-sap', \
     'results/peers/peers.dat' index 30 using 1:2 with lp pt 7 lw 1 title 'fcl-ccd', \
     'results/peers/peers.dat' index 31 using 1:2 with lp dt 2 pt 6 lw 1 title 'rapier', \
     'results/peers/peers.dat' index 32 using 1:2 with lp pt 7 lw 1 title 'parry-ccd'
unset multiplot
