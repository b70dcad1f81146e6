# cmake -DPAGE=viewer.html -DTHREE=three.min.js -DCONTROLS=OrbitControls.js -DVIEWER=viewer.js
#       -DOUT=viewer.html -P bundle.cmake: the page with the three scripts inlined.
file(READ ${PAGE} page)
foreach(part THREE CONTROLS VIEWER)
  file(READ ${${part}} text)
  # A script's text may not close its element.
  string(REPLACE "</script" "<\\/script" text "${text}")
  set(${part}_TEXT "${text}")
endforeach()
string(REPLACE "/*@three.min.js@*/" "${THREE_TEXT}" page "${page}")
string(REPLACE "/*@OrbitControls.js@*/" "${CONTROLS_TEXT}" page "${page}")
string(REPLACE "/*@viewer.js@*/" "${VIEWER_TEXT}" page "${page}")
file(WRITE ${OUT}.tmp "${page}")
file(RENAME ${OUT}.tmp ${OUT})
