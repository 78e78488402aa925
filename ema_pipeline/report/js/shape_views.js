
(function(){
var W=__VIEW_W__,H=__VIEW_H__,C=Math.cos(Math.PI/6);
function proj(x,y,z,v){if(v==='xy')return[x,-y];if(v==='xz')return[x,-z];
 if(v==='yz')return[y,-z];return[(x-y)*C,(x+y)*0.5-z];}
function all(el,sel){return [].slice.call(el.querySelectorAll(sel));}
function init(g){
 var data=JSON.parse(g.querySelector('script.shape-data').textContent);
 var q=function(s){return g.querySelector(s);};
 var views=all(g,'figure.shape-view');
 var st={scale:1,speed:0.5,view:data.view,run:true,t0:performance.now(),phase:0};
 q('.sv-view').value=data.view;
 var N=data.nodes.length,fit=null,L=data.surfaces.concat(data.lines);
 function amp(){return st.scale*data.share*data.size;}
 function refit(){var a=amp(),lo=[1e99,1e99],hi=[-1e99,-1e99];
  data.nodes.forEach(function(p){var s=proj(p[0],p[1],p[2],st.view);
   for(var k=0;k<2;k++){lo[k]=Math.min(lo[k],s[k]-a);hi[k]=Math.max(hi[k],s[k]+a);}});
  var sc=Math.min((W-8)/Math.max(hi[0]-lo[0],1e-12),(H-8)/Math.max(hi[1]-lo[1],1e-12));
  fit=[sc,(W-sc*(lo[0]+hi[0]))/2,(H-sc*(lo[1]+hi[1]))/2];
  views.forEach(function(v){draw(v,st.phase,true);});}
 function px(s){return [s[0]*fit[0]+fit[1],s[1]*fit[0]+fit[2]];}
 function pts(xy,idx){return idx.map(function(i){
  return xy[i][0].toFixed(1)+','+xy[i][1].toFixed(1);}).join(' ');}
 function draw(v,ph,all_){var d=data.modes[+v.getAttribute('data-key')].d,a=amp();
  var c=Math.cos(ph),s=Math.sin(ph),rest=[],xy=[];
  for(var i=0;i<N;i++){var p=data.nodes[i],o=6*i;
   rest.push(px(proj(p[0],p[1],p[2],st.view)));
   xy.push(px(proj(p[0]+a*(d[o]*c-d[o+3]*s),p[1]+a*(d[o+1]*c-d[o+4]*s),
                   p[2]+a*(d[o+2]*c-d[o+5]*s),st.view)));}
  if(all_){all(v,'.rest polygon,.rest polyline').forEach(function(el,k){
   el.setAttribute('points',pts(rest,L[k]));});}
  all(v,'.moved polygon,.moved polyline').forEach(function(el,k){
   el.setAttribute('points',pts(xy,L[k]));});
  all(v,'.moved circle').forEach(function(el,k){
   el.setAttribute('cx',xy[k][0].toFixed(1));el.setAttribute('cy',xy[k][1].toFixed(1));});}
 function tick(now){if(st.run&&g.getClientRects().length){
  st.phase=2*Math.PI*st.speed*(now-st.t0)/1000;
  views.forEach(function(v){draw(v,st.phase,false);});}requestAnimationFrame(tick);}
 q('.sv-scale').addEventListener('input',function(e){st.scale=+e.target.value;refit();});
 q('.sv-speed').addEventListener('input',function(e){var ph=st.phase;
  st.speed=+e.target.value;st.t0=performance.now()-1000*ph/(2*Math.PI*(st.speed||1));});
 q('.sv-view').addEventListener('change',function(e){st.view=e.target.value;refit();});
 q('.sv-pause').addEventListener('click',function(e){st.run=!st.run;
  st.t0=performance.now()-1000*st.phase/(2*Math.PI*(st.speed||1));
  e.target.textContent=st.run?'pause':'play';});
 window.addEventListener('beforeprint',function(){st.run=false;st.phase=0;
  views.forEach(function(v){draw(v,0,false);});});
 g.addEventListener('shape-key',refit);
 refit();requestAnimationFrame(tick);}
init(document.currentScript.parentNode);
})();
